"""Contact kernels run only on the blocks of elements in reach of their surface (ancf_sym.system.contact_reach),
for fixed surfaces and drums carried by bodies alike: the bound per pair is a lower bound of every gap the kernels
sample, the step graphs' values equal those of evaluating every element-surface pair, and a run through touch-down
and lift-off on a wheel carried by a body is the all-pairs run."""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ancf_sym import Material, Scene, Section
from ancf_sym.contact import gap as contact_gap
from ancf_sym.contact import laws
from ancf_sym.dynamics import DynamicOptions, simulate
from ancf_sym.dynamics.newton import NewtonOptions
from ancf_sym.model.assembly import Assembly
from ancf_sym.system import contact_reach
from ancf_sym.system.graph_cache import clear_graph_cache
from ancf_sym.system.step_system import StepSystem

R, N_EL, Z0 = 0.3, 16, 0.36
LAW = dict(stiffness=1e5, mu=0.3, eps=1e-2)


def _scene() -> Scene:
    """A cable3d rope (16 elements, 1.6 m) 5 cm above a wheel of radius 0.3 m (a spatial body on a revolute
    joint, axis y, friction), a fixed drum beside it and the ground below (both within reach only of the ends)."""
    sc = Scene(dim=3, gravity=(0.0, 0.0, -9.81))
    sc.member("rope", [(-0.7, 0.0, Z0), (0.9, 0.0, Z0)], N_EL, Material(E=2e8, density=1000.0), Section.circle(0.01))
    sc.body("wheel", 2.0, (0.05, 0.09, 0.05), position=(0.1, 0.0, 0.0))
    sc.revolute("wheel", point=(0.1, 0.0, 0.0), axis=(0, 1, 0))
    sc.contact_drum("rope", (0.1, 0.0, 0.0), R, axis=(0, 1, 0), body="wheel", **LAW)
    sc.contact_drum("rope", (-0.6, 0.0, -0.2), 0.1, axis=(0, 1, 0), damping=10.0, **LAW)
    sc.contact_ground("rope", level=-0.3, damping=10.0, **LAW)
    return sc


@pytest.fixture
def switch():
    """Set contact_reach.ENABLED (the step graphs are cached per structure: built again after each change)."""
    def set_(on: bool) -> None:
        contact_reach.ENABLED = on
        clear_graph_cache()
    yield set_
    set_(True)


def _states(asm: Assembly, rng) -> list[np.ndarray]:
    """The rope lowered onto the wheel by 0 .. 7 cm (out of reach, touching, pressed in), the wheel turned, random
    slopes' perturbations."""
    out = []
    mm = asm.mesh.members["rope"]
    for dz in (0.0, -0.049, -0.05, -0.051, -0.06, -0.07):
        x = asm.x0.copy()
        x[mm.offset + 2:mm.offset + mm.x0.size:6] += dz + 0.002 * rng.normal(size=mm.n_nodes)
        out.append(x)
    return out


def test_pair_bound_is_below_every_sampled_gap():
    """The bound per pair (ball about the chord's midpoint holding the Bezier control points) is at most the gap at
    every Gauss point the kernels sample: ground, fixed drum and the body's drum, in states in and out of contact
    with the wheel turned (the bound reads the drum's centre and axis from the body's coordinates)."""
    asm = Assembly(_scene())
    rng = np.random.default_rng(0)
    x = ca.MX.sym("x", asm.n)
    checked = 0
    for c in asm.scene.contacts:
        effect, idx, P = laws.kernel_call(c, asm.mesh, False)
        b = ca.Function("b", [x], [contact_reach.lower_bound("cable3d", effect, idx, ca.MX(ca.DM(P.T)), x, 3, {})])
        for X in _states(asm, rng):
            o = asm.mesh.bodies["wheel"]
            X[o + 3:o + 12] = np.array([[0.6, 0.0, -0.8], [0.0, 1.0, 0.0], [0.8, 0.0, 0.6]]).ravel()  # turned
            A, _ = contact_gap._rows(asm, c, X[None])
            sampled = contact_gap.sampled_gaps(c, A).min(axis=1)
            bound = np.asarray(b(X)).ravel()
            # a lower bound (1e-12 m: round-off of the two evaluations of the same geometry)
            assert np.all(bound <= sampled + 1e-12)
            checked += int(np.sum(bound <= 0.0))
    assert checked > 0  # pairs in reach were among them


def test_step_graphs_equal_all_pairs_bitwise(switch):
    """Gradient, Hessian and the dissipation's force and tangents of the step system with the switch on and off:
    the same numbers (the laws are exactly 0 out of reach), out of reach, at touch-down and pressed in."""
    asm = Assembly(_scene())
    rng = np.random.default_rng(1)
    X = _states(asm, rng)
    V = [rng.normal(size=asm.n) for _ in X]
    got = {}
    for on in (True, False):
        switch(on)
        S = StepSystem.for_scene(asm)
        vals = []
        for x, v in zip(X, V):
            xf, vf = S.reduce(x), S.reduce(v)
            g, K, _ = S.forces(xf)
            vals += [g, K.toarray(), np.asarray(S.grad_f(xf)).ravel()]
            vals += [np.asarray(ca.densify(o)) for o in S.damp_f(xf, vf)]
        got[on] = vals
    assert any(np.any(a != 0) for a in got[True][3::6])  # a state pressed the rope into the wheel
    for a, b in zip(got[True], got[False]):
        assert np.array_equal(a, b)


@pytest.mark.parametrize("modified", [False, True])
def test_run_through_touchdown_and_liftoff_equals_all_pairs(switch, modified):
    """The rope falls onto the wheel, which it turns by friction, and bounces off (touch-down and lift-off of pairs
    within steps): the run with the switch is the all-pairs run. Both solve the same equations with the same values
    at every iterate, so they agree to round-off of reordered sums; 1e-9 of the rope's size and speed bounds that
    with a wide margin, far below the Newton tolerance (1e-10 relative)."""
    runs = []
    for on in (True, False):
        switch(on)
        r = simulate(_scene(), DynamicOptions(dt=1e-3, t_end=0.25, output_dt=5e-3, record_states=True,
                                              newton=NewtonOptions(modified=modified)))
        assert r.success, r.message
        runs.append(r)
    a, b = runs
    assert np.abs(a.x - b.x).max() <= 1e-9
    assert np.abs(a.v - b.v).max() <= 1e-9 * max(1.0, np.abs(b.v).max())
    # touch-down and lift-off happened: the wheel's smallest gap below 0, later above it again
    asm = Assembly(_scene())
    wheel = asm.scene.contacts[0]
    gaps = np.array([contact_gap.closest(asm, wheel, x).gap for x in b.states])
    first = int(np.argmax(gaps < 0))
    assert gaps[first] < 0 and np.any(gaps[first:] > 0), gaps


def test_drive_reaction_without_its_jacobian_is_the_same_force():
    """The work bookkeeping's drive reaction J^T y without forming J equals the sparse product (sums of the same
    terms in another order: 1e-12 relative)."""
    sc = _scene()
    sc.drive("wheel", omega=[(0.0, 0.0), (1.0, 2.0)])
    asm = Assembly(sc)
    d = StepSystem.for_scene(asm).drives
    rng = np.random.default_rng(3)
    x, y = asm.x0 + 0.01 * rng.normal(size=asm.n), rng.normal(size=d.m)
    for t in (0.0, 0.5):
        ref = d.jacobian(x, d.w(t)).T @ y
        assert np.abs(ref).max() > 0
        assert np.allclose(d.transpose_product(x, d.w(t), y), ref, rtol=0, atol=1e-12 * np.abs(ref).max())
