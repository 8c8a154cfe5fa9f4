"""Dynamics: energy behaviour of the integrators, constraints, sensors, step rejection and bad input.

Small scenes (4-8 elements, <= 1 s) so the whole file runs in a few seconds on a loaded machine.
"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from ancf_sym import Material, Scene, SceneError, Section
from ancf_sym.model.assembly import Assembly
from ancf_sym.dynamics.collocation import tableau
from ancf_sym.dynamics import DynamicOptions, run_dynamics, simulate

ZHANG = dict(material=Material(E=20e9, density=7200), section=Section(area=7.854e-5, I=4.909e-10))
TIP = [{"name": "tip", "kind": "position", "member": "beam", "at": "end"}]


def pendulum(n=4, axial="biot"):
    """Paper 000's 3 m beam pinned at one end, horizontal, under gravity."""
    s = Scene(dim=2, gravity=(0, -9.81))
    s.member("beam", [(0, 0), (3, 0)], n, axial=axial, **ZHANG)
    s.pin("beam", "start")
    return s


def zigzag_bar(n=8):
    """A straight steel bar pinned at one end, no gravity, with alternating axial nodal velocities: the energy sits
    in the highest axial modes."""
    s = Scene(dim=2)
    s.member("bar", [(0, 0), (1, 0)], n, Material(E=200e9, density=7800), Section.circle(0.01), axial="green",
             bending=False, gravity=False)
    s.pin("bar", "start")
    a = Assembly(s)
    v0 = np.zeros(a.n)
    mm = a.mesh.members["bar"]
    for k in range(1, mm.n_nodes):
        v0[mm.node_dofs(k)[0]] = 1e-3 * (-1) ** k
    return s, v0


# -- energy ----------------------------------------------------------------------------------------------------

def test_newmark_energy_error_is_second_order_and_bounded():
    """Trapezoidal Newmark on a conservative nonlinear scene: |E(t) - E(0)| <= C h^2 (ratio 4 when h halves),
    no drift; HHT and generalized-alpha dissipate (algorithmic energy >= 0 and larger than Newmark's)."""
    errs = []
    for dt in (4e-3, 2e-3):
        r = run_dynamics(pendulum(), {"integrator": "newmark", "dt": dt, "t_end": 1.0, "output_every": 1})
        assert r.status == "completed"
        errs.append(np.max(np.abs(r.energies["algorithmic"])))
    scale = np.max(np.abs(r.energies["potential"]))
    assert errs[1] / scale < 5e-5
    assert 3.5 < errs[0] / errs[1] < 4.5
    ga = run_dynamics(pendulum(), {"integrator": "generalized_alpha", "rho_inf": 0.5, "dt": 2e-3, "t_end": 1.0,
                                   "output_every": 1})
    assert ga.energies["algorithmic"].min() > -1e-9 * scale
    assert ga.energies["algorithmic"][-1] > r.energies["algorithmic"][-1]


@pytest.mark.parametrize("integrator,keeps", [("newmark", True), ("gauss", True), ("hht", False),
                                               ("generalized_alpha", False), ("radau", False)])
def test_high_frequency_dissipation(integrator, keeps):
    """omega_max h = 10 on the highest axial modes: Newmark and Gauss keep the energy; HHT (alpha = -1/3) and
    generalized-alpha (rho_inf = 0.5) remove it as their spectral radius says (0.5 per step), Radau IIA as well.
    The vibration amplitude is 2.6 nm, below Newton's default update tolerance (1e-10 m x the scene length), so
    Newton runs here to full convergence (at least two iterations, no truncation-error-relative tolerance): the
    energy is the scheme's. With the defaults Newmark keeps it to ~6e-6."""
    s, v0 = zigzag_bar()
    h = 10 / 3.868e5  # omega_max of this bar (generalized eigenvalues of K and M at the reference state)
    r = run_dynamics(s, {"integrator": integrator, "dt": h, "t_end": 100 * h, "output_every": 10, "rho_inf": 0.5,
                         "alpha": -1 / 3, "v0": v0, "newton": {"lte_fraction": 0.0, "single": False}})
    assert r.status == "completed"
    ratio = r.energies["total"][-1] / r.energies["total"][0]
    if keeps:
        assert abs(ratio - 1) < 1e-6
    else:
        assert ratio < 0.05


def test_rayleigh_damping_work_closes_the_balance():
    s = pendulum()
    s.rayleigh(alpha=0.5, beta=1e-3)
    r = run_dynamics(s, {"integrator": "newmark", "dt": 2e-3, "t_end": 0.6, "output_every": 10})
    W = r.energies["damping_work"]
    assert np.all(np.diff(W) > 0)
    assert np.max(np.abs(r.energies["algorithmic"])) < 0.02 * W[-1]


def test_time_load_external_work():
    """A triangular force pulse (paper 002's impulse load) on the tip of the pinned beam without gravity: the
    balance books its work, E(t) - E(0) = external work - algorithmic (Newmark: small)."""
    s = Scene(dim=2)
    s.member("beam", [(0, 0), (3, 0)], 4, axial="biot", gravity=False, **ZHANG)
    s.pin("beam", "start")
    r = run_dynamics(s, {"integrator": "newmark", "dt": 1e-3, "t_end": 0.05, "output_every": 5,
                         "loads": [{"member": "beam", "at": "end", "force": [0, 1.0],
                                    "history": [[0, 0], [0.01, 1], [0.02, 0]]}],
                         "sensors": [{"name": "tip", "kind": "displacement", "member": "beam", "at": "end"}]})
    assert r.status == "completed"
    W = r.energies["external_work"]
    assert W[-1] > 0 and W[-1] == pytest.approx(W[-2])  # no work after the pulse
    assert np.max(np.abs(r.energies["algorithmic"])) < 1e-4 * W.max()
    assert r.sensors["tip"][-1, 1] > 1e-3


# -- agreement, constraints, sensors ---------------------------------------------------------------------------

def test_integrators_agree_on_the_pendulum():
    tips = {}
    for name, extra in (("newmark", {}), ("hht", {"alpha": -0.005}), ("generalized_alpha", {}),
                        ("radau", {"stages": 2}), ("gauss", {"stages": 2})):
        r = run_dynamics(pendulum(), {"integrator": name, "dt": 2e-3, "t_end": 0.5, "output_times": [0.5],
                                      "sensors": TIP, **extra})
        tips[name] = r.sensors["tip"][-1]
    ref = tips["gauss"]
    for name, tip in tips.items():
        assert np.max(np.abs(tip - ref)) < 2e-3, name
    assert ref[1] < -1.0  # it fell


def test_modified_newton_matches_full_newton():
    opts = {"integrator": "generalized_alpha", "dt": 2e-3, "t_end": 0.4, "output_times": [0.4], "sensors": TIP}
    a = run_dynamics(pendulum(), opts)
    b = run_dynamics(pendulum(), {**opts, "newton": {"modified": True}})
    assert np.max(np.abs(a.sensors["tip"] - b.sensors["tip"])) < 1e-6  # both within their Newton tolerances
    assert b.counters["factorizations"] < b.counters["newton_iterations"]


def test_modified_newton_in_the_step_graph_keeps_chaotic_motion():
    """The compiled modified-Newton step (LDL^T factor kept across steps) on paper 002's hinged double pendulum
    with a penalty hinge, a chaotic motion that amplifies every per-step error: it ends where full Newton does
    (accepting a kept factor's iteration on a predicted contraction, tried before, ended 9 mm off)."""
    steel, sec = Material(E=200e9, density=7800), Section.circle(0.02)
    tips = {}
    for modified in (False, True):
        s = Scene(dim=2, gravity=(0, -9.81))
        s.member("a", [(0, 0), (0.5, 0)], 2, steel, sec, axial="green")
        s.member("b", [(0.5, 0), (1.0, 0)], 2, steel, sec, axial="green")
        s.pin("a", "start")
        s.hinge(("a", "end"), ("b", "start"), method="penalty", penalty=1e-2)
        r = run_dynamics(s, {"integrator": "hht", "alpha": -0.005, "dt": 1e-3, "t_end": 0.5, "output_dt": 0.25,
                             "newton": {"modified": modified},
                             "sensors": [{"name": "tip", "kind": "position", "member": "b", "at": "end"}]})
        assert r.status == "completed"
        tips[modified] = r.sensors["tip"][-1]
        if modified:
            assert r.factorizations < 0.9 * r.steps
    assert np.max(np.abs(tips[True] - tips[False])) < 1e-4


@pytest.mark.parametrize("method", ["exact", "penalty"])
def test_double_pendulum_hinge(method):
    """Paper 002's hinged double pendulum (steel, 2 cm, 2 x 0.5 m, two elements each, HHT alpha = -0.005,
    dt = 1e-3): the exact hinge identifies coordinates, the penalty hinge (0.01 EA / 1 m) keeps the joint within
    0.1 mm (the paper reports 94 um); both give the same motion to the penalty's accuracy."""
    steel, sec = Material(E=200e9, density=7800), Section.circle(0.02)
    s = Scene(dim=2, gravity=(0, -9.81))
    s.member("a", [(0, 0), (0.5, 0)], 2, steel, sec, axial="green")
    s.member("b", [(0.5, 0), (1.0, 0)], 2, steel, sec, axial="green")
    s.pin("a", "start")
    s.hinge(("a", "end"), ("b", "start"), method=method, penalty=1e-2 if method == "penalty" else None)
    r = run_dynamics(s, {"integrator": "hht", "alpha": -0.005, "dt": 1e-3, "t_end": 0.5, "output_dt": 0.25,
                         "sensors": [{"name": "tip", "kind": "position", "member": "b", "at": "end"}]})
    assert r.status == "completed"
    viol = r.constraint_violation.max()
    assert viol < (1e-12 if method == "exact" else 1e-4)
    np.testing.assert_allclose(r.sensors["tip"][-1], [-0.2139, -0.9370], atol=2e-3)


def test_rigid_T_pendulum_keeps_the_right_angle():
    """Rigid joint (bilinear constraint, Lagrange multiplier, sparse QR in the step)."""
    steel, sec = Material(E=200e9, density=7800), Section.circle(0.02)
    s = Scene(dim=2, gravity=(0, -9.81))
    s.member("a", [(0, 0), (0.5, 0)], 2, steel, sec, axial="green")
    s.member("b", [(0.5, 0), (0.5, -0.5)], 2, steel, sec, axial="green")
    s.pin("a", "start")
    s.rigid(("a", "end"), ("b", "start"))
    r = run_dynamics(s, {"integrator": "hht", "alpha": -0.005, "dt": 1e-3, "t_end": 0.3, "output_dt": 0.1,
                         "sensors": [{"name": "ja", "kind": "coordinates", "member": "a", "at": "end"},
                                     {"name": "jb", "kind": "coordinates", "member": "b", "at": "start"}]})
    assert r.status == "completed"
    ta, tb = r.sensors["ja"][:, 2:4], r.sensors["jb"][:, 2:4]
    cosang = np.sum(ta * tb, axis=1) / np.linalg.norm(ta, axis=1) / np.linalg.norm(tb, axis=1)
    assert np.max(np.abs(cosang)) < 1e-8
    assert r.constraint_violation.max() < 1e-9
    assert r.energy_error() < 1e-3


def test_sensors_output_times_and_to_dict():
    sensors = TIP + [{"name": "v", "kind": "velocity", "member": "beam", "at": "end"},
                     {"name": "u", "kind": "displacement", "member": "beam", "at": 1.5},
                     {"name": "eps", "kind": "strain", "member": "beam", "at": 1.5},
                     {"name": "kappa", "kind": "curvature", "member": "beam", "at": 0.75}]
    base = {"integrator": "generalized_alpha", "dt": 2e-3, "t_end": 0.3, "sensors": sensors}
    r = run_dynamics(pendulum(), {**base, "output_every": 1})
    ri = run_dynamics(pendulum(), {**base, "output_times": [0.0, 0.1001, 0.3]})
    np.testing.assert_allclose(ri.t, [0.0, 0.1001, 0.3])
    k = int(round(0.1 / 2e-3))
    # Hermite interpolation between steps: close to the step values around it
    np.testing.assert_allclose(ri.sensors["tip"][1], r.sensors["tip"][k], atol=5e-4)
    np.testing.assert_allclose(ri.sensors["tip"][-1], r.sensors["tip"][-1], atol=1e-12)
    # velocity sensor ~ finite difference of the position sensor
    fd = np.gradient(r.sensors["tip"], r.t, axis=0)
    assert np.max(np.abs(fd[5:-5] - r.sensors["v"][5:-5])) < 1e-2 * np.max(np.abs(r.sensors["v"]))
    assert r.sensors["eps"].shape == (len(r.t), 1) and np.all(np.abs(r.sensors["eps"]) < 1e-3)
    assert np.all(r.sensors["kappa"] >= 0)
    d = json.loads(json.dumps(r.to_dict()))
    assert d["status"] == "completed" and d["steps"] == 150 and len(d["t"]) == 151
    assert set(d["sensors"]) == {"tip", "v", "u", "eps", "kappa"}
    for key in ("newton_iterations", "factorizations", "jacobians", "residuals", "wall_s", "rejected_steps"):
        assert key in d


def test_adaptive_step_control():
    ref = run_dynamics(pendulum(), {"integrator": "generalized_alpha", "dt": 5e-4, "t_end": 0.6,
                                    "output_times": [0.6], "sensors": TIP})
    r = run_dynamics(pendulum(), {"integrator": "generalized_alpha", "dt": 1e-3, "t_end": 0.6, "adaptive": True,
                                  "tol": 1e-5, "output_times": [0.3, 0.6], "sensors": TIP})
    assert r.status == "completed" and r.steps < 1200
    assert r.h_max > 1e-3
    assert np.max(np.abs(r.sensors["tip"][-1] - ref.sensors["tip"][-1])) < 2e-3


# -- failures --------------------------------------------------------------------------------------------------

def test_step_rejection_is_recorded_and_recovered():
    """dt = 0.1 s is far too large for the first Newton solve of the released beam: the step is halved (each
    attempt recorded with its reason) until Newton converges, and the run completes."""
    r = run_dynamics(pendulum(axial="green"), {"dt": 0.1, "t_end": 0.4, "newton": {"max_iter": 6}})
    assert r.status == "completed" and r.t_reached == pytest.approx(0.4)
    assert len(r.rejected) >= 1
    first = r.rejected[0]
    assert first["t"] == 0.0 and first["h"] == 0.1 and "newton" in first["reason"]
    assert r.h_min < 0.1


def test_newton_failure_ends_with_last_good_state():
    r = run_dynamics(pendulum(axial="green"), {"dt": 0.05, "t_end": 1.0, "dt_min": 0.05, "newton": {"max_iter": 4},
                                               "output_every": 1, "sensors": TIP})
    assert r.status == "newton_failed" and not r.success
    assert r.t_reached < 1.0 and "dt_min" in r.message
    assert np.all(np.isfinite(r.x)) and np.all(np.isfinite(r.v))
    assert np.all(np.isfinite(r.sensors["tip"])) and r.t[-1] == pytest.approx(r.t_reached)
    assert len(r.rejected) == 1
    json.dumps(r.to_dict(), allow_nan=False)


@pytest.mark.parametrize("analysis,match", [
    ({"dt": 0}, "dt"), ({"dt": -1e-3}, "dt"), ({"dt": float("nan")}, "dt"), ({"dt": float("inf")}, "dt"),
    ({"dt": "x"}, "dt"), ({"t_end": 0.0}, "t_end"), ({"t_end": float("inf")}, "t_end"), ({"t_end": -1}, "t_end"),
    ({"output_times": [0.5, 2.0]}, "output_times"), ({"output_times": [-0.1]}, "output_times"),
    ({"output_dt": 0}, "output_dt"), ({"output_every": 0}, "output_every"),
    ({"integrator": "rk4"}, "integrator"), ({"rho_inf": 1.5}, "rho_inf"), ({"integrator": "hht", "alpha": -0.5}, "alpha"),
    ({"integrator": "radau", "stages": 7}, "stages"), ({"newton": {"tol": -1}}, "newton.tol"),
    ({"newton": {"maxiter": 3}}, "newton"), ({"dtt": 1}, "dtt"), ({"sensors": [{"kind": "position", "member": "x"}]}, "member"),
    ({"sensors": [{"kind": "speed", "member": "beam"}]}, "kind"), ({"dt_min": 1.0}, "dt_min"),
    ({"q0": [0.0, 1.0]}, "q0"), ({"loads": [{"member": "beam", "force": [0, 1], "history": [[1, 0], [0, 1]]}]}, "history"),
])
def test_bad_input_is_refused_before_any_step(analysis, match):
    base = {"dt": 1e-3, "t_end": 1.0}
    calls = []
    with pytest.raises(SceneError, match=match):
        run_dynamics(pendulum(), {**base, **analysis}, progress=lambda t, te: calls.append(t))
    assert calls == []


def test_initial_state_violating_constraints_is_refused():
    s = pendulum()
    a = Assembly(s)
    q0 = a.x0.copy()
    q0[0] += 1e-3  # moves the pinned node
    with pytest.raises(SceneError, match="q0 violates constraint 'pin beam@start'"):
        simulate(s, DynamicOptions(dt=1e-3, t_end=0.1, q0=q0))


def test_tableaux():
    for kind, s, order in (("radau", 1, 1), ("radau", 2, 3), ("radau", 3, 5), ("gauss", 1, 2), ("gauss", 2, 4),
                           ("gauss", 3, 6)):
        t = tableau(kind, s)
        assert t.order == order
        np.testing.assert_allclose(t.A.sum(axis=1), t.c, atol=1e-13)  # row sums
        np.testing.assert_allclose(t.b.sum(), 1.0, atol=1e-13)
        for k in range(order):  # b . c^k = 1/(k+1) up to the order
            assert math.isclose(t.b @ t.c**k, 1 / (k + 1), rel_tol=1e-12)
    np.testing.assert_allclose(tableau("radau", 2).A, [[5 / 12, -1 / 12], [3 / 4, 1 / 4]], atol=1e-14)


# -- strain-rate damping ---------------------------------------------------------------------------------------

def test_strain_rate_damping_dissipates_and_books():
    """Kelvin-Voigt damping of the released beam: positive dissipation, the balance closes (Newmark), the tip
    moves less; the step matrix is unsymmetric (d f_d / dq) and Newton still converges in ~1 iteration."""
    free = run_dynamics(pendulum(), {"integrator": "newmark", "dt": 2e-3, "t_end": 1.0, "output_dt": 0.25,
                                     "sensors": TIP})
    s = pendulum()
    s.strain_rate_damping(axial=200.0, bending=0.5)
    r = run_dynamics(s, {"integrator": "newmark", "dt": 2e-3, "t_end": 1.0, "output_dt": 0.25, "sensors": TIP})
    W = r.energies["damping_work"]
    assert np.all(np.diff(W) > 0) and W[-1] > 0.1
    # what is left is Newmark's own O(h^2) energy error of this nonlinear beam, as without damping
    assert np.max(np.abs(r.energies["algorithmic"])) < 2 * np.max(np.abs(free.energies["algorithmic"]))
    assert r.newton_iterations < 1.5 * r.steps
    assert np.linalg.norm(r.sensors["tip"][-1] - free.sensors["tip"][-1]) > 1e-3


def test_strain_rate_damping_leaves_rigid_motion_alone():
    """A free cable spinning about its midpoint has no strain rate: no damping work (Rayleigh alpha would damp it)."""
    s = Scene(dim=2)
    s.member("c", [(-0.5, 0), (0.5, 0)], 4, Material(E=2e9, density=1000), Section.circle(0.01), axial="green",
             gravity=False)
    s.strain_rate_damping(axial=100.0, bending=1.0)
    a = Assembly(s)
    v0 = np.zeros(a.n)
    mm = a.mesh.members["c"]
    w = 2.0  # rad/s: v = w x r for positions, w x r_x for slopes
    for k in range(mm.n_nodes):
        d = mm.node_dofs(k)
        x, tx = a.x0[d[0]], a.x0[d[2]]
        v0[d[1]], v0[d[3]] = w * x, w * tx
    r = run_dynamics(s, {"integrator": "generalized_alpha", "dt": 1e-3, "t_end": 0.5, "output_dt": 0.1, "v0": v0})
    assert r.status == "completed"
    T0 = r.energies["kinetic"][0]
    assert r.energies["damping_work"][-1] < 1e-6 * T0
    assert abs(r.energies["kinetic"][-1] / T0 - 1) < 1e-3


def test_strain_rate_damping_bad_input():
    s = pendulum()
    with pytest.raises(SceneError, match="axial"):
        s.strain_rate_damping(axial=-1.0)
    with pytest.raises(SceneError, match="members"):
        s.strain_rate_damping(axial=1.0, members=["nope"])
