"""Dynamic sensitivities from every start a run can have (ancf_sym.sensitivity.run_start, start_derivative): the
static equilibrium with supports released, a rotation of that equilibrium (its velocities read the coordinates,
which the parameters move), prescribed rotations from the reference, given coordinates and velocities, and an
earlier run's result.json; forward against Richardson-extrapolated central differences of re-run scenes, the adjoint
against the forward.

Differences of runs: Newton to xtol = 1e-13 of the length, so the runs' own error (~1e-13 relative) divided by the
parameter step 1e-3 leaves ~1e-10, and Richardson removes the O(s^2) truncation (~1e-6 of the step's square): the
issue's 1e-5 relative bound holds with margin. A missing term errs by more: the rotation's dv_0/dq_0 by 1e-3 to
3e-3 of the sensor's record, the damping's d(C v_0 + f_d)/dq in the initial acceleration by 8e-4 to 7e-3, its
d(C v_0 + f_d)/dv by 3e-5 to 1.5e-4 (the damped static start with a rotation). Forward and adjoint solve the
transposed linear equations of the same scheme: round-off of ~50 sparse solves, far inside 1e-8."""
from __future__ import annotations

import copy
import json

import numpy as np
import pytest

from ancf_sym.dynamics import DynamicOptions
from ancf_sym.dynamics.newton import NewtonOptions
from ancf_sym.dynamics.sensors import Sensor, SensorEval
from ancf_sym.sensitivity import get_parameter, with_parameter
from ancf_sym.sensitivity.adjoint import SensorOutput, dynamic_gradient
from ancf_sym.sensitivity.alpha_run import run_for_sensitivity
from ancf_sym.sensitivity.dynamics import dynamic_sensitivity

DOC = {"scene": {"name": "p", "dim": 2, "gravity": [0.0, -9.81]},
       "materials": {"m": {"E": 5e6, "density": 1200.0}}, "sections": {"s": {"area": 1e-4, "I": 1e-9}},
       "members": [{"name": "rope", "points": [[0, 0], [1.0, 0]], "elements": 6, "material": "m", "section": "s",
                    "bending": True}],
       "supports": [{"type": "pin", "member": "rope", "at": "start"}, {"type": "pin", "member": "rope", "at": "end"}],
       "loads": [{"type": "force", "member": "rope", "at": 0.5, "value": [0.0, -0.5]}],
       "dampings": [{"type": "rayleigh", "alpha": 2.0}]}
# (the beta and strain-rate dampings' forces at a moving start depend on q_0: d(C v_0)/dq, df_d/dq enter a_0)
DAMPED = copy.deepcopy(DOC)
DAMPED["dampings"] = [{"type": "rayleigh", "alpha": 2.0, "beta": 2e-4}, {"type": "strain_rate", "axial": 0.5}]
ONE_PIN = copy.deepcopy(DOC)
ONE_PIN["supports"] = ONE_PIN["supports"][:1]
TIGHT = NewtonOptions(xtol=1e-13, tol=1e-12, lte_fraction=0.0, single=False)
SENSORS = [{"name": "mid", "kind": "position", "member": "rope", "at": 3},
           {"name": "tip_v", "kind": "velocity", "member": "rope", "at": "end"}]
PATHS = ["materials.m.E", "scene.gravity[1]", "materials.m.density", "dampings[0].alpha", "loads[0].value[1]"]
ROTATE = [{"member": "rope", "omega": 2.0}]  # (about the pin at the origin: the supports allow it)


def options(**kw) -> DynamicOptions:
    return DynamicOptions(dt=2e-3, t_end=0.1, newton=TIGHT, sensors=SENSORS, **kw)


def integral_weights(t: np.ndarray) -> np.ndarray:
    w = np.zeros(len(t))
    w[:-1] += np.diff(t) / 2
    w[1:] += np.diff(t) / 2
    return w


def mid_integral(doc: dict, o: DynamicOptions) -> float:
    r = run_for_sensitivity(doc, [], o)
    ev = SensorEval(Sensor.from_dict(SENSORS[0], 0), r.asm, 0)
    return float(integral_weights(r.t) @ np.array([ev.probe.r(x)[1] for x in r.X]))


def richardson(f, doc: dict, path: str) -> float:
    v = get_parameter(doc, path)
    s = 1e-3 * abs(v)

    def D(h):
        return (f(with_parameter(doc, path, v + h)) - f(with_parameter(doc, path, v - h))) / (2 * h)
    return (4 * D(s / 2) - D(s)) / 3


def result_file(tmp_path, doc: dict) -> str:
    """A result.json of an earlier run (its final coordinates and velocities), as ancf-sym run writes them."""
    r = run_for_sensitivity(doc, [], DynamicOptions(dt=2e-3, t_end=0.05, newton=TIGHT))
    p = tmp_path / "result.json"
    p.write_text(json.dumps({"success": True, "x": r.X[-1].tolist(), "v": r.V_full[-1].tolist()}))
    return str(p)


def case(name: str, tmp_path):
    if name == "release":
        return DOC, options(start="static", release=["pin rope@end"])
    if name == "release_rotating_damped":
        return DAMPED, options(start="static", release=["pin rope@end"], initial=ROTATE)
    if name == "static_rotating_damped":
        return DAMPED, options(start="static", initial=ROTATE)
    if name == "initial_rotation":
        return ONE_PIN, options(initial=ROTATE)
    if name == "q0_v0":
        r = run_for_sensitivity(ONE_PIN, [], DynamicOptions(dt=2e-3, t_end=0.05, newton=TIGHT, initial=ROTATE))
        return ONE_PIN, options(q0=r.X[-1], v0=r.V_full[-1])
    return ONE_PIN, options(from_result=result_file(tmp_path, ONE_PIN))


CASES = ["release", "release_rotating_damped", "static_rotating_damped", "initial_rotation", "q0_v0", "from_result"]


@pytest.mark.parametrize("name", CASES)
def test_start_sensitivities_match_central_differences(name, tmp_path):
    doc, o = case(name, tmp_path)
    fw = dynamic_sensitivity(doc, PATHS, o)
    w = integral_weights(fw.t)
    for p in PATHS:
        ref = richardson(lambda d: mid_integral(d, o), doc, p)
        got = w @ fw.sensor(p, "mid")[:, 1]
        assert abs(got - ref) <= 1e-5 * abs(ref), (name, p, got, ref)


@pytest.mark.parametrize("name", CASES)
def test_start_adjoint_equals_forward(name, tmp_path):
    doc, o = case(name, tmp_path)
    fw = dynamic_sensitivity(doc, PATHS, o)
    for out, ref_of in ((SensorOutput("mid", 1, "integral"),
                         lambda p: integral_weights(fw.t) @ fw.sensor(p, "mid")[:, 1]),
                        (SensorOutput("tip_v", 0, "end"), lambda p: fw.sensor(p, "tip_v")[-1, 0])):
        g = dynamic_gradient(doc, PATHS, o, out)
        for p in PATHS:
            ref = ref_of(p)
            assert abs(g.gradient[p] - ref) <= 1e-8 * max(abs(ref), 1e-12), (name, out, p)


def test_released_start_differs_from_the_held_run():
    """The released run's derivative is not the held scene's: the start is the held equilibrium, the run moves
    once released (a check that the test above sees the release at all)."""
    held = dynamic_sensitivity(DOC, ["materials.m.density"], options(start="static"))
    rel = dynamic_sensitivity(DOC, ["materials.m.density"], options(start="static", release=["pin rope@end"]))
    assert len(rel.x[0]) == len(held.x[0])
    np.testing.assert_allclose(rel.dx["materials.m.density"][0], held.dx["materials.m.density"][0], rtol=1e-10,
                               atol=1e-16)  # (same static start: the held scene's equilibrium)
    d_rel = rel.sensor("materials.m.density", "mid")[-1, 1]
    d_held = held.sensor("materials.m.density", "mid")[-1, 1]
    assert abs(d_rel - d_held) > 0.1 * abs(d_held)


def test_cli_release(tmp_path):
    """`ancf-sym run` of a scene file with a static start and a support released (the pendulum example held at
    both ends, then let go at one) with --sensitivity: the tip's derivative at every output time (output_dt off
    the step grid: interpolated) against differences of the package's own runs of that file (run_dynamics), 1e-5."""
    import subprocess
    import sys
    import tomllib
    from pathlib import Path

    from ancf_sym.dynamics import run_dynamics
    from ancf_sym.io.scene_toml import scene_from_dict

    text = (Path(__file__).resolve().parents[2] / "examples" / "scenes" / "pendulum.toml").read_text()
    text = text.replace("t_end = 1.0", "t_end = 0.05\nstart = \"static\"\nrelease = [\"pin beam@end\"]")
    text = text.replace("output_dt = 0.02", "output_dt = 0.0013")
    # (Newton converged tightly, lte_fraction = 0: the default stops at a fraction of the step's truncation error,
    # whose scatter between runs, ~1e-7 m, would dominate differences over the parameter step)
    text = text.replace("sensors = [", "newton = { xtol = 1e-13, tol = 1e-12, lte_fraction = 0.0, single = false }\n"
                        "sensors = [")
    text += '\n[[supports]]\ntype = "pin"\nmember = "beam"\nat = "end"\n'
    scene_file = tmp_path / "pendulum.toml"
    scene_file.write_text(text)
    out = tmp_path / "d"
    path = "scene.gravity[1]"
    subprocess.run([sys.executable, "-m", "ancf_sym.cli", "run", str(scene_file), "--out", str(out), "--quiet",
                    "--no-animation", "--sensitivity", path], check=True, cwd=tmp_path)
    data = json.loads((out / "result.json").read_text())
    got = data["sensitivities"][path]
    assert got["t"] == data["t"] and len(got["t"]) == 40 and not got.get("notes")
    doc = tomllib.loads(text)

    def tip(d):
        scene, analysis = scene_from_dict(d)
        return run_dynamics(scene, analysis).sensors["tip"][:, 1]
    ref = richardson(tip, doc, path)
    d_cli = np.asarray(got["sensors"]["tip"])[:, 1]
    assert np.max(np.abs(d_cli - ref)) <= 1e-5 * np.max(np.abs(ref))


def test_release_is_read_from_the_options():
    """A scene built again from the same document shares the cached assembly (whose scene is the first one built):
    whether supports were released is the options', not a comparison of scene objects."""
    for _ in range(2):
        assert not run_for_sensitivity(DOC, [], options(start="static")).start.released
    assert run_for_sensitivity(DOC, [], options(start="static", release=["pin rope@end"])).start.released
