"""Optimal control (ancf_sym.control): exact derivatives against central differences, the crane and minimum-time
examples in their --quick form (the figures they promise), refusals of bad input before any solve, and an
infeasible problem that reports IPOPT's status and its last point instead of raising.

Derivative tolerances: central differences with step 1e-6 on O(1) coordinates have truncation ~1e-12 x the next
derivative and round-off ~1e-16 x |g| / 1e-6 ~ 1e-10 relative to the largest entry; entries here reach 1e7 (EA / L),
so the checks are relative to the largest entry with 1e-6."""
from __future__ import annotations

import importlib.util
import json
import math
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from ancf_sym import Material, Scene, SceneError, Section
from ancf_sym.control import ControlProblem, Effort, MinimumTime, PathConstraint, PointForce, PointMass, SupportMotion, Swing

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
G = 9.81


def rope(n=2, axial="green", bending=True, dim=2, length=5.0):
    s = Scene(dim=dim, gravity=(0.0, -G) if dim == 2 else (0.0, 0.0, -G))
    end = (0.0, -length) if dim == 2 else (0.0, 0.0, -length)
    s.member("rope", points=[(0.0,) * dim, end], elements=n, material=Material(E=100e9, density=7850),
             section=Section(area=7.85e-5, I=1e-11), axial=axial, bending=bending)
    s.pin("rope", "start")
    return s


def trolley(**kw):
    return SupportMotion("rope", "start", name="trolley", **kw)


def crane(n=2, K=4, **kw):
    args = dict(controls=[trolley()], horizon=4.0, point_masses=[PointMass("rope", "end", 100.0)], cost=[Effort()],
                end={"trolley.position": 2.0}, intervals=K, stages=3)
    args.update(kw)
    return ControlProblem(rope(n), **args)


# -- exact derivatives ---------------------------------------------------------------------------------------------

def _offset(v):
    return (v.point("rope", "end")[0] - v["trolley.position"]) ** 2


CASES = {
    "radau free time, swing cost, path": lambda: ControlProblem(
        rope(2), controls=[trolley()], horizon=(2.0, 4.0, 6.0), point_masses=[PointMass("rope", "end", 100.0)],
        cost=[Effort(), MinimumTime(), Swing(0.1)], end={"trolley.position": 2.0}, intervals=3, stages=2,
        path=[PathConstraint(_offset, 0.0, 0.1)], terminal=[PathConstraint(_offset, 0.0, 0.0)]),
    "gauss, force control, biot without bending": lambda: ControlProblem(
        rope(2, axial="biot", bending=False), controls=[trolley(), PointForce("rope", "end", (1.0, 0.0), "push")],
        horizon=3.0, point_masses=[PointMass("rope", "end", 50.0)], cost=[Effort(weights={"push": 1e-4})],
        end={"trolley.position": 1.0}, intervals=3, stages=2, scheme="gauss"),
    "cable3d, two axes, decoupled, constant controls": lambda: ControlProblem(
        rope(1, axial="decoupled", dim=3), controls=[SupportMotion("rope", "start", axes=(0, 1), name="t")],
        horizon=3.0, point_masses=[PointMass("rope", "end", 20.0)], cost=[Effort()],
        end={"t_x.position": 1.0, "t_y.position": 0.5}, intervals=2, stages=2, control_form="constant"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_jacobian_and_hessian_match_central_differences(case):
    """jac_g (kernel Hessians, assembled) against differences of g (from the energy kernels' reverse companions:
    another code path), and hess_lag (third-derivative kernels, assembled) against differences of
    sigma grad f + J^T lambda, at a perturbed warm start with random multipliers."""
    ocp = CASES[case]()
    w0, _ = ocp.warm_start()
    rng = np.random.default_rng(3)
    w = w0 + 0.01 * rng.standard_normal(ocp.nw)
    if ocp.free_time:
        w[ocp.iT] = 3.7

    def g(x):
        return np.asarray(ocp.g_function(x)).ravel()

    def jac(x):
        return np.asarray(ca.densify(ocp.jac_g(x, [])[1]))
    gj = np.asarray(ocp.jac_g(w, [])[0]).ravel()
    assert np.abs(gj - g(w)).max() <= 1e-9 * max(np.abs(g(w)).max(), 1.0)  # both kernels' gradients agree
    h = 1e-6
    E = np.eye(ocp.nw)
    J = jac(w)
    Jfd = np.column_stack([(g(w + h * e) - g(w - h * e)) / (2 * h) for e in E])
    assert np.abs(J - Jfd).max() <= 1e-6 * np.abs(Jfd).max(), case
    lam, sigma = rng.standard_normal(ocp.ng), 0.7
    gradf = ca.Function("gf", [ocp.nlp["x"]], [ca.gradient(ocp.nlp["f"], ocp.nlp["x"])])

    def grad_lag(x):
        return sigma * np.asarray(gradf(x)).ravel() + jac(x).T @ lam
    H = np.asarray(ca.densify(ocp.hess_lag(w, [], sigma, lam)))
    Hfd = np.column_stack([(grad_lag(w + h * e) - grad_lag(w - h * e)) / (2 * h) for e in E])
    Hfd = np.triu(0.5 * (Hfd + Hfd.T))
    assert np.abs(np.tril(H, -1)).max() == 0.0  # IPOPT reads the upper triangle only
    assert np.abs(H - Hfd).max() <= 1e-6 * np.abs(Hfd).max(), case


# -- the examples ---------------------------------------------------------------------------------------------------

def run_example(name, tmp_path_factory):
    spec = importlib.util.spec_from_file_location(f"example_{name}", EXAMPLES / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    tmp = tmp_path_factory.mktemp(name)
    js, out = tmp / f"{name}.json", tmp / "figures"
    records = mod.main(["--quick", "--json", str(js), "--out", str(out)])
    on_disk = json.loads(js.read_text())
    assert len(on_disk) == len(records) > 0
    assert all(all(not isinstance(v, (dict, list)) for v in r.values()) for r in on_disk), "records must be flat"
    assert sorted(out.glob("*.png")), f"{name} drew no figure"
    return mod, records


@pytest.fixture(scope="module")
def crane_example(tmp_path_factory):
    return run_example("crane_ocp", tmp_path_factory)


def test_crane_records(crane_example):
    _, recs = crane_example
    for key in ("n", "intervals", "cost", "residual_swing_m", "ipopt_status", "wall_s"):
        assert all(key in r for r in recs), key
    assert all(r["ipopt_status"] == "Solve_Succeeded" for r in recs)
    assert {(r["n"], r["intervals"]) for r in recs} == {(2, 8), (4, 8), (4, 16)}


def test_crane_no_residual_swing(crane_example):
    """Re-simulated by the dynamics integrator, the optimal move leaves the payload swinging by well under a
    millimetre (measured 0.1-0.3 mm: the modes above the grid's resolution are left free), the quintic move of the
    same length and time by about a metre (linear pendulum theory: 1.096 m); the collocation trajectory and the
    re-simulation agree to a millimetre."""
    _, recs = crane_example
    for r in recs:
        assert r["residual_swing_m"] < 1e-3, r
        assert r["mismatch_m"] < 1e-3, r
        assert r["naive_residual_swing_m"] == pytest.approx(1.096, rel=0.02)


def test_crane_cost_converges_and_matches_the_pendulum(crane_example):
    """Minimum effort of the linearised rigid pendulum (point mass on a massless 5 m rod), rest to rest over 2 m in
    4 s: 3.3323 m^2/s^3 (controllability Gramian). The rope's own mass (3 % of the payload) and its stretch lower
    the swing frequency by 0.3 % and the optimum by 0.4 %; K = 8 and 16 intervals agree to 1e-5."""
    _, recs = crane_example
    costs = {(r["n"], r["intervals"]): r["cost"] for r in recs}
    assert costs[(4, 8)] == pytest.approx(costs[(4, 16)], rel=1e-5)
    assert costs[(2, 8)] == pytest.approx(costs[(4, 8)], rel=1e-5)
    assert costs[(4, 16)] == pytest.approx(3.3323, rel=0.01)


@pytest.fixture(scope="module")
def mintime_example(tmp_path_factory):
    return run_example("minimum_time_swing", tmp_path_factory)


def test_minimum_time(mintime_example):
    """The swing limit costs time: T(no limit) > 3 s (a rigid load under the same bounds) and T(0.1 m) > T(none);
    between the collocation points the re-simulated payload exceeds the limit by a few per cent at most."""
    _, recs = mintime_example
    assert all(r["ipopt_status"] == "Solve_Succeeded" for r in recs)
    free = next(r for r in recs if r["swing_limit_m"] is None)
    lim = next(r for r in recs if r["swing_limit_m"] == 0.1)
    assert 3.0 < free["T_s"] < lim["T_s"] < 12.0
    assert lim["max_offset_m"] < 0.1 * 1.05
    assert free["max_offset_m"] > 0.3  # without a limit the optimum swings far
    assert all(r["residual_swing_m"] < 1e-3 for r in recs)


# -- other schemes and controls -----------------------------------------------------------------------------------

def test_gauss_and_constant_controls_agree_with_radau():
    radau = crane(K=8).solve()
    gauss = crane(K=8, scheme="gauss").solve()
    const = crane(K=16, control_form="constant").solve()
    assert radau.success and gauss.success and const.success
    assert gauss.cost == pytest.approx(radau.cost, rel=1e-4)
    # piecewise constant: a smaller control space, first order in h (measured +3.9 % at K = 16)
    assert radau.cost < const.cost < 1.06 * radau.cost
    assert np.ptp(const.U.reshape(16, 3), axis=1).max() == 0.0


def test_force_control_helps():
    """A horizontal force on the payload as a second control (cheap in the effort weights) lowers the optimum."""
    base = crane(n=2, K=6).solve()
    both = crane(n=2, K=6, controls=[trolley(), PointForce("rope", "end", (1.0, 0.0), "push")],
                 cost=[Effort(weights={"push": 1e-4})]).solve()
    assert base.success and both.success
    assert both.cost < 0.9 * base.cost


def test_terminal_constraints_instead_of_modal_rest():
    """end_rest=False with terminal constraints of our own (payload below the trolley and moving with it): the same
    optimum as the modal rest condition to 1e-3, and no residual swing in the re-simulation."""
    def below_and_along(v):
        return ca.vertcat(v.point("rope", "end")[0] - v["trolley.position"],
                          v.velocity("rope", "end")[0] - v["trolley.velocity"])
    ref = crane(K=10).solve()
    own = crane(K=10, end_rest=False, terminal=[PathConstraint(below_and_along, 0.0, 0.0, "no swing")]).solve()
    assert own.success and own.prob.n_end_modes == 0
    assert own.cost == pytest.approx(ref.cost, rel=1e-3)
    assert own.resimulate(after=5.0).residual_swing_m < 1e-3


def test_result_and_resimulation_api():
    res = crane(K=6).solve()
    assert res.success and res.iterations > 0 and res.wall_s > 0
    x, v = res.channel("trolley")
    assert x[0] == 0.0 and x[-1] == pytest.approx(2.0) and abs(v[-1]) < 1e-12
    assert res.point("rope", "end").shape == (len(res.t_nodes), 2)
    kt = res.kernel_time()
    assert 0 < kt["kernel_s"] < kt["solve_s"] and 0 < kt["share_of_solve"] < 1
    assert res.ipopt_times()["nlp_hess_l"]["calls"] >= res.iterations
    rep = res.resimulate(after=1.0)
    assert rep.success and rep.integrator == "radau" and rep.after == 1.0
    assert rep.t[-1] == pytest.approx(res.T + 1.0)
    assert set(res.to_dict()) >= {"status", "cost", "iterations", "wall_s"}


# -- bad input: refused before solving ------------------------------------------------------------------------------

@pytest.mark.parametrize("kw,match", [
    ({"horizon": 0.0}, "horizon must be positive"),
    ({"horizon": -2.0}, "horizon must be positive"),
    ({"horizon": float("nan")}, "horizon: must be finite"),
    ({"horizon": (3.0, 2.0, 5.0)}, "horizon must be one number"),
    ({"horizon": 4.0, "cost": [MinimumTime()]}, r"needs horizon=\(lower, guess, upper\)"),
    ({"horizon": (0.0, 2.0, 5.0), "cost": [MinimumTime()]}, "0 < lower <= guess <= upper"),
    ({"bounds": {"trolley.acceleration": (1.0, -1.0)}}, "infeasible: lower > upper"),
    ({"bounds": {"trolley.position": (-1.0, 1.0)}}, "outside its bounds"),
    ({"bounds": {"trolley.acceleration": (-0.1, 0.1)}}, "needs an acceleration of at least 0.5"),
    ({"bounds": {"trolley.velocity": (-0.1, 0.1)}}, "at the velocity bound"),
    ({"bounds": {"trolley.velocity": (0.5, 1.0)}}, "excludes rest"),
    ({"bounds": {"trolly.velocity": (-1, 1)}}, "unknown name 'trolly.velocity'"),
    ({"end": {"trolley.velocity": 1.0}}, "unknown name"),
    ({"controls": [SupportMotion("rope", "end", name="trolley")]}, "no pin or clamp there"),
    ({"controls": [SupportMotion("rope", 1, name="trolley")]}, "no pin or clamp there"),
    ({"controls": [SupportMotion("hoist", "start", name="trolley")]}, "member 'hoist' does not exist"),
    ({"controls": [SupportMotion("rope", "start", axes=(2,), name="trolley")]}, "axes must be distinct axes"),
    ({"controls": []}, "controls must be a non-empty list"),
    ({"intervals": 0}, "intervals must be a positive integer"),
    ({"scheme": "euler"}, "scheme must be one of"),
    ({"stages": 7}, "stages must be an integer in 1..4"),
    ({"point_masses": [PointMass("rope", "end", -1.0)]}, "mass: must be positive"),
    ({"path": [PathConstraint(_offset, 1.0, 0.0)]}, "infeasible"),
    ({"control_form": "spline"}, "control_form must be"),
    ({"terminal": [PathConstraint(lambda v: 1.0, 0.0, 0.0)]}, "does not depend on the state"),
    ({"max_iter": 0}, "max_iter must be a positive integer"),
])
def test_bad_input_is_refused_before_solving(kw, match):
    with pytest.raises(SceneError, match=match):
        crane(**kw)


def test_unsupported_scenes_are_refused():
    s = rope(2)
    s.moment("rope", "end", 1.0)
    with pytest.raises(SceneError, match="moment loads"):
        ControlProblem(s, controls=[trolley()], horizon=4.0)
    s = rope(2)
    s.rayleigh(alpha=0.1)
    with pytest.raises(SceneError, match="damping"):
        ControlProblem(s, controls=[trolley()], horizon=4.0)


def test_infeasible_problem_reports_status_and_point():
    """2 m in 3 s with |a| <= 1 m/s^2 passes the necessary check (0.89 m/s^2 needed for a rigid load) but the payload
    cannot stay within 1 cm of the trolley: IPOPT's status, its last point and the violations come back, no
    exception."""
    ocp = crane(horizon=3.0, K=6, bounds={"trolley.acceleration": (-1.0, 1.0)}, max_iter=25,
                path=[PathConstraint(lambda v: v.point("rope", "end")[0] - v["trolley.position"], -0.01, 0.01)])
    res = ocp.solve()
    assert not res.success
    assert res.status and res.status not in ("Solve_Succeeded", "Solved_To_Acceptable_Level")
    assert [a["method"] for a in res.attempts] == ["full steps", "line search"]
    assert np.all(np.isfinite(res.w)) and res.w.shape == (ocp.nw,)
    assert res.constraint_violation > 1e-3
    assert set(res.violations) == {"dynamics", "kinematics", "end", "path", "bounds"}
    assert math.isfinite(res.cost)


def test_resimulation_refused_without_moving_frame():
    """A rope between two pins with one of them moved: solvable, but the moving-frame re-simulation does not apply
    and says so."""
    s = Scene(dim=2, gravity=(0.0, -G))
    s.member("rope", points=[(0.0, 0.0), (2.0, 0.0)], elements=2, material=Material(E=1e9, density=1000),
             section=Section(area=1e-4, I=1e-10), axial="green")
    s.pin("rope", "start")
    s.pin("rope", "end")
    ocp = ControlProblem(s, controls=[SupportMotion("rope", "end", axes=(1,), name="lift")], horizon=1.0,
                         end={"lift.position": 0.05}, intervals=4, stages=2)
    res = ocp.solve()
    assert res.success
    with pytest.raises(SceneError, match="only position support"):
        res.resimulate()


def test_ctrl_c_inside_ipopt_stops_the_solve(monkeypatch):
    """CasADi catches the KeyboardInterrupt that SIGINT raises inside IPOPT and returns a failed status; the control
    solve must stop (KeyboardInterrupt), not report a failure or try its line-search attempt. The stand-in solver
    swallows the interrupt as CasADi does, so the test fails without the re-raise."""
    import os
    import signal

    ocp = crane()

    class Swallowing:
        def __call__(self, **kw):
            try:
                os.kill(os.getpid(), signal.SIGINT)
                for _ in range(1000):  # Python runs the signal handler between bytecodes: give it some
                    pass
            except KeyboardInterrupt:
                return {"x": kw["x0"], "lam_g": np.zeros(ocp.ng)}
            raise AssertionError("SIGINT was not delivered")

        def stats(self):
            return {"return_status": "NonIpopt_Exception_Thrown"}

    monkeypatch.setattr(ocp, "solver", lambda full_steps: Swallowing())
    with pytest.raises(KeyboardInterrupt):
        ocp.solve()
