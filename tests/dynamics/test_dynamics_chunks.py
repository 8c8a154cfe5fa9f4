"""Compiled chunks stop at the first step they cannot accept, and compiled step graphs are reused by scenes of the
same structure (other E, dt, loads, initial state)."""
from __future__ import annotations

import numpy as np
from ancf_sym import Material, Scene, Section
from ancf_sym.model.assembly import Assembly
from ancf_sym.dynamics import DynamicOptions, simulate
from ancf_sym.dynamics.alpha import AlphaIntegrator
from ancf_sym.dynamics.newton import Counters, NewtonOptions
from ancf_sym.dynamics.schemes import Scheme
from ancf_sym.system.step_system import StepSystem
from ancf_sym.system.graph_cache import clear_graph_cache


def pendulum(n=6, E=2e9, rho=7200.0, g=9.81, L=1.0, A=1e-4, I=1e-9):
    s = Scene(dim=2, gravity=(0.0, -g))
    s.member("m", [(0.0, 0.0), (L, 0.0)], n, Material(E=E, density=rho), Section(area=A, I=I), axial="biot")
    s.pin("m", "start")
    return s


def integrator(scene):
    S = StepSystem(Assembly(scene))
    integ = AlphaIntegrator(S, Scheme.generalized_alpha(0.9), NewtonOptions(), 0.0, 1e-10, Counters())
    integ.initialize(S.reduce(S.asm.x0), np.zeros(S.nf), np.zeros(S.nf))
    integ.tol_q = 1e-8 * float(np.max(np.abs(S.f_lin)))
    return S, integ


def test_a_chunk_stops_at_the_first_step_it_cannot_accept():
    """A non-finite load at step 4 of an 8-step chunk: the chunk accepts steps 1-3 (the same states as three
    single steps: the same compiled step). A small state's first chunk runs unguarded (the later steps run on,
    their results discarded); that early failure turns the guard on, and in a guarded chunk steps 4-8 do no Newton
    iteration (the guard's no-op), so the chunk's cost is that of the steps it took."""
    S, integ = integrator(pendulum())
    S1, one = integrator(pendulum())
    h = 1e-3
    pl = np.repeat(-S.f_lin[:, None], 8, axis=1)
    pl[:, 3] = np.nan
    assert not integ.guard
    states, n_ok = integ.run_chunk(h, pl)
    assert n_ok == 3 and states.shape[0] == 3
    for _ in range(3):
        assert one.attempt(0.0, h).converged
        one.accept()
    assert np.allclose(integ.q, one.q, rtol=0, atol=1e-14 * S.span)  # identical arithmetic: round-off only
    assert integ.guard  # an early failure: guarded chunks from now on
    states, n_ok = integ.run_chunk(h, pl)
    assert n_ok == 3
    info = integ._chunks[8, True][2]["info"].reshape(8, integ.info_size)
    assert np.all(info[:3, 0] == 1) and np.all(info[:3, 1] >= 1)
    assert info[3, 0] == 0  # the failing step
    assert np.all(info[4:] == 0)  # no work after it
    for _ in range(3):
        assert one.attempt(0.0, h).converged
        one.accept()
    assert np.allclose(integ.q, one.q, rtol=0, atol=1e-14 * S.span)


def test_hard_transient_stays_in_the_chunks(monkeypatch):
    """Zhang's pendulum on a fine mesh released horizontal with a long step (early steps need 4-5 Newton iterations):
    every grid step is taken in the chunks' compiled step (no single step left to `attempt`), and the run equals the
    same run step by step (the same compiled step graph: round-off only, far below the 1e-9 m asked here)."""
    opts = dict(dt=4e-3, t_end=0.256, integrator="generalized_alpha", rho_inf=0.9, output_dt=0.064, energies=False,
                sensors=[{"name": "tip", "kind": "position", "member": "m", "at": "end"}])
    import ancf_sym.dynamics.time_loop as D
    calls = []
    attempt = AlphaIntegrator.attempt
    monkeypatch.setattr(AlphaIntegrator, "attempt", lambda self, *a, **k: calls.append(1) or attempt(self, *a, **k))
    zhang = dict(n=300, E=20e9, L=3.0, A=7.854e-5, I=4.909e-10)
    chunked = simulate(pendulum(**zhang), DynamicOptions(**opts))
    assert not calls
    monkeypatch.setattr(D, "chunk_size", lambda n: 0)
    stepwise = simulate(pendulum(**zhang), DynamicOptions(**opts))
    assert len(calls) == 64
    assert chunked.status == stepwise.status == "completed"
    assert chunked.steps == 64 and not chunked.rejected
    assert chunked.counters["newton_iterations"] > 1.5 * chunked.steps  # a hard transient
    assert chunked.counters == stepwise.counters
    assert np.max(np.abs(chunked.sensors["tip"] - stepwise.sensors["tip"])) < 1e-9


def test_same_structure_reuses_the_compiled_graphs():
    """A second scene with other E, gravity (a constant load), dt and initial velocity reuses the first one's
    compiled functions (the same objects: no graph building), and its run equals a run whose graphs were built
    afresh (same arithmetic: round-off only); another density (mass matrix baked in) builds new graphs."""
    clear_graph_cache()
    S1 = StepSystem(Assembly(pendulum()))
    S2 = StepSystem(Assembly(pendulum(E=4e9, g=5.0)))
    assert S2.graph_key == S1.graph_key and S2.iter_f is S1.iter_f and S2.forces_pf is S1.forces_pf
    assert StepSystem(Assembly(pendulum(rho=2000.0))).graph_key != S1.graph_key
    v0 = np.zeros(S2.asm.n)
    v0[1::4] = np.linspace(0.0, 0.2, S2.asm.n // 4)
    opts = DynamicOptions(dt=5e-4, t_end=0.05, integrator="generalized_alpha", v0=v0, output_dt=0.01,
                          sensors=[{"name": "tip", "kind": "position", "member": "m", "at": "end"}])
    cached = simulate(S2.asm, opts, system=S2)
    clear_graph_cache()
    fresh = simulate(pendulum(E=4e9, g=5.0), opts)
    assert np.max(np.abs(cached.sensors["tip"] - fresh.sensors["tip"])) < 1e-12
    for k in fresh.energies:
        assert np.allclose(cached.energies[k], fresh.energies[k], rtol=1e-12, atol=1e-12)
    other = simulate(pendulum(E=2e9, g=5.0), opts)  # the element parameters are inputs, not stale constants
    assert np.max(np.abs(other.sensors["tip"] - fresh.sensors["tip"])) > 1e-7


def test_integrators_of_one_structure_share_step_and_chunk_functions():
    clear_graph_cache()
    _, a = integrator(pendulum())
    S = StepSystem(Assembly(pendulum(E=3e9)))
    b = AlphaIntegrator(S, Scheme.generalized_alpha(0.9), NewtonOptions(), 0.0, 1e-10, Counters())
    assert b.step_f is a.step_f
    assert b.chunk_function(8) is not a.chunk_function(8)  # own buffers...
    assert a._graphs["chunks"][8, False] is b._graphs["chunks"][8, False]  # ...on one compiled function
    c = AlphaIntegrator(S, Scheme.generalized_alpha(0.5), NewtonOptions(), 0.0, 1e-10, Counters())
    assert c.step_f is not a.step_f  # other scheme coefficients: another graph


def test_a_large_state_runs_its_chunk_step_by_step_and_stops_at_the_first_failure():
    """Large states (>= chunks.LARGE_STATE entries) build no chunk graph: the chunk is the step graph called once
    per step, ending at the first step it cannot accept (a non-finite load at step 4 of 8). The accepted states
    are those of three single steps (the same compiled step: round-off only), and the failing step's work is
    counted but nothing after it."""
    scene = pendulum(n=130)
    S, integ = integrator(scene)
    _, one = integrator(scene)
    assert integ.stepwise
    h = 1e-3
    pl = np.repeat(-S.f_lin[:, None], 8, axis=1)
    pl[:, 3] = np.nan
    states, n_ok = integ.run_chunk(h, pl)
    assert n_ok == 3 and states.shape[0] == 3
    its = integ.counters.newton_iterations
    for k in range(3):
        assert one.attempt(0.0, h).converged
        one.accept()
        assert np.allclose(states[k, :S.nf], one.q, rtol=0, atol=1e-14 * S.span)
    assert np.allclose(integ.q, one.q, rtol=0, atol=1e-14 * S.span)
    assert np.allclose(integ.a_prev, one.a_prev, rtol=0, atol=1e-12 * np.abs(one.a_prev).max())
    assert its >= one.counters.newton_iterations + 1  # the failing step's iteration(s) too
    assert not integ._graphs["chunks"]  # no chunk graph built


def test_newton_functions_outside_the_step_graph_are_built_on_first_use():
    """A full-Newton run whose steps all converge in the compiled step graph builds neither the step residual nor
    the step Jacobian (modified Newton and Newton in Python use them); their first use builds them once for the
    structure (a second system of it gets the same objects), and they describe the same equations as the compiled
    iteration: the Newton update solved from their residual and KKT matrix equals the compiled one's to round-off
    (tolerance 1e-9 relative: the step matrix is dominated by M / (beta h^2), condition number ~1e4 here)."""
    clear_graph_cache()
    S, integ = integrator(pendulum())
    integ.run_chunk(1e-3, np.repeat(-S.f_lin[:, None], 32, axis=1))
    assert "res_f" not in S._graphs and "jac_f" not in S._graphs
    S.x[:] = S.reduce(S.asm.x0)
    S.x[1::4] -= 1e-3 * np.linspace(0.0, 1.0, S.x[1::4].size)  # a bent state
    S.p[:] = -S.f_lin - 2e6 * (S.M @ S.x)
    S.cm[0], S.cc[0] = 1e6, 1e3
    S.jacobian()
    r = S.r.copy()
    dz_py = -np.linalg.solve(S.kkt.toarray(), r)
    dz = S.iterate().copy()
    assert "res_f" in S._graphs and "jac_f" in S._graphs
    assert np.max(np.abs(dz_py - dz)) < 1e-9 * np.max(np.abs(dz))
    rg = S.residual()  # the same residual from the gradient-only kernels
    assert np.max(np.abs(rg - r)) < 1e-10 * np.max(np.abs(r))
    S2 = StepSystem(Assembly(pendulum(E=4e9)))
    assert S2.res_f is S.res_f and S2.jac_f is S.jac_f


def test_kernel_companions_load_once_and_mapped_calls_follow_the_graph_cache():
    """The kernels' (energy, gradient) and energy companions are one compiled function per process, like the
    kernels; the kernels mapped over a structure's elements are kept with the step graphs and forgotten with them."""
    from ancf_sym import kernels
    from ancf_sym.model.assembly import MAPPED_CALLS, map_elements
    assert kernels.load_grad("cable2d", "axial_biot") is kernels.load_grad("cable2d", "axial_biot")
    assert kernels.load_energy("cable2d", "bending") is kernels.load_energy("cable2d", "bending")
    one = kernels.load_grad("cable2d", "axial_biot")
    f = map_elements(one, None, 7)
    assert map_elements(one, None, 7) is f and f.size2_in(0) == 7
    clear_graph_cache()
    assert not MAPPED_CALLS and map_elements(one, None, 7) is not f
