"""Sensitivities of lines in water (ancf_sym.sensitivity.water_derivative) against central differences of re-solved
scenes: statics (buoyancy, the water line, a current's drag), frequencies (the added mass, the water line) and dynamic
runs (drag on the velocity relative to current and waves, the added mass, the waves' fluid inertia), forward and
adjoint, for the model's own parameters and the water's (density, current, Morison coefficients, wave height).

Tolerances: the issue's figures (1e-6 relative for statics and frequencies, 1e-5 for dynamics). The differences are
Richardson-extrapolated (O(h^4) truncation: ~1e-8 at h = 1e-2 relative, ~1e-12 at 1e-3) of solves converged far below
that (statics tol 1e-13, Newton to 1e-13 of the length in the runs), so a right derivative meets them, while
a missing term (the buoyancy's share of a density, the drag's velocity Jacobian, the added mass's change) errs by
O(1e-2..1). Adjoint against forward: the same linear equations transposed, ~100 sparse solves: 1e-8."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from ancf_sym.dynamics import DynamicOptions, simulate
from ancf_sym.dynamics.newton import NewtonOptions
from ancf_sym.io.scene_toml import scene_from_dict
from ancf_sym.modal import modal_analysis
from ancf_sym.scene import SceneError
from ancf_sym.sensitivity import get_parameter, with_parameter
from ancf_sym.sensitivity.adjoint import SensorOutput, dynamic_gradient
from ancf_sym.sensitivity.api import sensitivities
from ancf_sym.sensitivity.dynamics import dynamic_sensitivity
from ancf_sym.sensitivity.modal import ModalSensitivity
from ancf_sym.sensitivity.static import StaticSensitivity
from ancf_sym.statics.problem import StaticOptions, problem_for

SCENE = Path(__file__).resolve().parents[2] / "examples" / "scenes" / "mooring_line.toml"


def mooring(current: bool = True, waves: bool = False, ca_axial: float = 0.5, elements: int = 6,
            fairlead: float = -2.0) -> dict:
    """A steel rope 15 % longer than the span between an anchor at 20 m depth and a fairlead (cf. mooring_line.toml)."""
    d = {"scene": {"name": "mooring", "dim": 2, "gravity": [0.0, -9.81]},
         "materials": {"steel": {"E": 2e9, "density": 7800.0}},
         "sections": {"rope": {"shape": "circle", "diameter": 0.03}},
         "members": [{"name": "line", "points": [[0.0, -20.0], [24.0, fairlead]], "elements": elements,
                      "material": "steel", "section": "rope", "axial": "biot", "bending": False,
                      "prestrain": -0.15}],
         "supports": [{"type": "pin", "member": "line", "at": "start"},
                      {"type": "pin", "member": "line", "at": "end"}],
         "water": {"density": 1025.0, "depth": 20.5,
                   "lines": {"line": {"cd": 1.2, "cd_axial": 0.05, "ca": 1.0, "ca_axial": ca_axial}}}}
    if current:
        d["water"]["current"] = [0.6, 0.0]
    if waves:
        d["water"]["waves"] = {"height": 2.0, "period": 8.0}
    return d


def richardson(f, doc: dict, path: str, rel: float = 1e-3) -> np.ndarray:
    v = get_parameter(doc, path)
    h = rel * abs(v)

    def D(s):
        return (f(with_parameter(doc, path, v + s)) - f(with_parameter(doc, path, v - s))) / (2 * s)
    return (4 * D(h / 2) - D(h)) / 3


def _solve(doc: dict):
    scene, _ = scene_from_dict(doc)
    r = problem_for(scene).solve(StaticOptions(tol=1e-13))
    assert r.success, r.status
    return scene, r


def _static_record(doc: dict) -> np.ndarray:
    _, r = _solve(doc)
    cf = r.constraint_forces
    return np.r_[np.asarray(r.x), r.potential, r.energies["gravity"], cf["pin line@start"], cf["pin line@end"]]


def _relative(an: np.ndarray, fd: np.ndarray) -> float:
    return float(np.max(np.abs(an - fd)) / np.max(np.abs(fd)))


@pytest.mark.parametrize("case,paths", [
    ("current", ["water.density", "water.current[0]", "water.lines.line.cd", "water.lines.line.cd_axial",
                 "materials.steel.density", "materials.steel.E", "sections.rope.diameter", "scene.gravity[1]",
                 "members[0].prestrain"]),
    ("water_line", ["water.density", "sections.rope.diameter", "scene.gravity[1]", "water.current[0]",
                    "members[0].prestrain"]),
    ("hydro_diameter", ["water.lines.line.diameter", "sections.rope.diameter", "materials.steel.density"]),
    ("profile", ["water.current[0][1][0]", "water.current[1][1][0]", "water.current[2][1][0]"]),
])
def test_static_sensitivities_in_water_match_central_differences(case, paths):
    doc = mooring(fairlead=0.5 if case == "water_line" else -2.0)  # (0.5: the top pierces the surface)
    if case == "hydro_diameter":
        doc["water"]["lines"]["line"]["diameter"] = 0.05  # (buoyancy, drag on 5 cm: not the section's 3 cm)
    if case == "profile":  # (a current by height, piecewise linear: linear in its points' velocities)
        doc["water"]["current"] = [[-20.0, [0.3, 0.0]], [-10.0, [0.5, 0.0]], [0.0, [0.8, 0.0]]]
    scene, r = _solve(doc)
    s = StaticSensitivity(scene, r, doc)
    n = len(r.x)
    for p in paths:
        d = s.derivative(p)
        an = np.r_[s.dx(p), d["potential"], d["energies"]["gravity"], d["constraint_forces"]["pin line@start"],
                   d["constraint_forces"]["pin line@end"]]
        fd = richardson(_static_record, doc, p, rel=1e-2)  # (at 1e-3 the solves' round-off over the step reaches
        # 5e-7 of the support forces' small derivative by E; measured here: 9e-9, 2e-9, 6e-8 for the three cases)
        assert _relative(an[:n], fd[:n]) <= 1e-6, (p, "positions")
        assert np.all(np.abs(an[n:n + 2] - fd[n:n + 2]) <= 1e-6 * np.abs(fd[n:n + 2])), (p, "potential, gravity")
        assert _relative(an[n + 2:], fd[n + 2:]) <= 1e-6, (p, "support forces")


def test_static_sensitivities_on_the_seabed():
    """A line 30 % longer than the span, resting partly on the seabed (its penalty ground contact) in the current:
    the seabed's stiffness is a parameter too. The perturbed scenes are solved from the equilibrium (from the
    straight start this slack line can find another equilibrium, or a hidden penetration, and the 'difference' is
    wrong by orders of magnitude)."""
    doc = mooring(elements=10)
    doc["members"][0]["prestrain"] = -0.3
    doc["water"].update(depth=20.0, seabed={"stiffness": 1e5})
    scene, r = _solve(doc)
    assert r.energies["contact"] > 0  # (it rests on the seabed)
    s = StaticSensitivity(scene, r, doc)
    n = len(r.x)

    def record(d):
        rr = problem_for(scene_from_dict(d)[0]).solve(StaticOptions(tol=1e-13), r.x)
        assert rr.success, rr.status
        return np.r_[rr.x, rr.potential, rr.constraint_forces["pin line@end"]]
    for p in ["water.seabed.stiffness", "water.density", "water.current[0]", "sections.rope.diameter"]:
        d = s.derivative(p)
        an = np.r_[s.dx(p), d["potential"], d["constraint_forces"]["pin line@end"]]
        fd = richardson(record, doc, p)
        assert _relative(an[:n], fd[:n]) <= 1e-6 and abs(an[n] - fd[n]) <= 1e-6 * abs(fd[n]), p
        assert _relative(an[n + 1:], fd[n + 1:]) <= 1e-6, p


FAIRLEAD = {"type": "position", "member": "line", "at": "end", "name": "fairlead",
            "position": [[[0.0, [24.0, 0.0, 1.0]]], -2.0]}  # (x = 24 + t^2 m: a surge from rest)


def test_static_sensitivities_with_the_fairlead_held_by_a_drive():
    """The fairlead held by a position drive (its value at t = 0) instead of a pin: its force's derivative."""
    doc = mooring()
    doc["supports"] = doc["supports"][:1]
    doc["drives"] = [FAIRLEAD]
    scene, r = _solve(doc)
    s = StaticSensitivity(scene, r, doc)
    n = len(r.x)

    def record(d):
        _, rr = _solve(d)
        return np.r_[rr.x, rr.constraint_forces["fairlead"]]
    for p in ["water.density", "water.current[0]", "materials.steel.E"]:
        an = np.r_[s.dx(p), s.derivative(p)["constraint_forces"]["fairlead"]]
        fd = richardson(record, doc, p, rel=1e-2)
        assert _relative(an[:n], fd[:n]) <= 1e-6 and _relative(an[n:], fd[n:]) <= 1e-6, p


def test_static_adjoint_in_a_current_is_the_transpose():
    """The drag's load stiffness makes the tangent unsymmetric: the adjoint gradient solves the transposed system
    (solved untransposed it is off by 3e-2 to 0.14 here)."""
    doc = mooring()
    scene, r = _solve(doc)
    s = StaticSensitivity(scene, r, doc)
    paths = ["water.current[0]", "water.lines.line.cd", "materials.steel.E"]
    dJdx = np.zeros(len(r.x))
    dJdx[s.asm.mesh.members["line"].node_dofs(3)[0]] = 1.0  # (the middle node's x)
    g = s.gradient(dJdx, paths)
    for k, p in enumerate(paths):
        ref = float(dJdx @ s.dx(p))
        assert abs(g[k] - ref) <= 1e-10 * abs(ref), p


def _frequencies(doc: dict) -> np.ndarray:
    scene, r = _solve(doc)
    return modal_analysis(scene, modes=4, static=r).frequencies


@pytest.mark.parametrize("current", [False, True], ids=["still", "current"])
def test_frequency_sensitivities_in_water_match_central_differences(current):
    """The top piercing the surface (the water line's stiffness), ca != ca_axial (the added mass turns with the
    equilibrium's tangents); in a current the drag's load stiffness makes K unsymmetric (the left eigenvectors enter,
    and the drag's coefficients and the current are parameters). The section's diameter scales mass, weight, buoyancy, added mass and EA alike
    (as d^2): the frequencies' derivative is nil there, checked against the scale f / d. Steps of 1e-2 of the value:
    the frequencies' round-off (statics and eigen solves, ~1e-13 relative) over a step of 1e-3 reaches 1e-6 of
    the small derivatives by ca_axial and E (measured: 9e-7 and 2e-6 there, 1.2e-7 and 2e-7 at 1e-2, whose
    extrapolated truncation is ~1e-8)."""
    doc = mooring(current=current, fairlead=0.5)
    paths = ["water.density", "water.lines.line.ca", "water.lines.line.ca_axial", "materials.steel.density",
             "materials.steel.E", "scene.gravity[1]", "members[0].prestrain", "sections.rope.diameter"]
    if current:
        paths += ["water.current[0]", "water.lines.line.cd", "water.lines.line.cd_axial"]
    s = sensitivities(doc, paths, modes=4)
    f = _frequencies(doc)
    for p in paths:
        fd = richardson(_frequencies, doc, p, rel=1e-2)
        an = s[p]["frequencies"]
        scale = np.abs(fd) if p != "sections.rope.diameter" else f / get_parameter(doc, p)
        assert np.all(np.abs(an - fd) <= 1e-6 * scale), (p, an, fd)


def test_mode_shape_sensitivities_in_still_water():
    """d(M-normalised shapes)/dp (Nelson's bordered system) with the water line's and the turning added mass's
    changes along the equilibrium's (ca != ca_axial), against differences of the perturbed scenes' shapes."""
    doc = mooring(current=False, fairlead=0.5)
    scene, r = _solve(doc)
    ms = ModalSensitivity(modal_analysis(scene, modes=3, static=r), scene, doc)

    def shapes(d):
        sc, rr = _solve(d)
        return modal_analysis(sc, modes=3, static=rr).shapes
    for p in ["water.density", "water.lines.line.ca_axial", "members[0].prestrain", "scene.gravity[1]"]:
        assert _relative(ms.shape_derivative(p), richardson(shapes, doc, p, rel=1e-2)) <= 1e-6, p


TIGHT = NewtonOptions(xtol=1e-13, tol=1e-12, lte_fraction=0.0, single=False)
SENSORS = [{"name": "mid", "kind": "position", "member": "line", "at": 0.5}]


@pytest.mark.parametrize("case", ["waves", "current_static_start", "fairlead_surge"])
def test_dynamic_sensitivities_in_water_forward_adjoint_and_differences(case):
    """waves: a taut line from its reference in a current and Airy waves (drag on the relative velocity, fluid
    inertia); current_static_start: the slack line from its equilibrium in a current, pulled sideways by a time
    load (the start's sensitivity with the drag's load stiffness); fairlead_surge: the waves' case with the fairlead
    moved by a position drive (a KKT step whose time inputs end with the waves' time). Added mass isotropic (ca = ca_axial = 1), ca alone
    as a parameter (the turning added mass's derivative at ca = ca_axial)."""
    doc = mooring(waves=case != "current_static_start", ca_axial=1.0, elements=5)
    if case == "fairlead_surge":
        doc["members"][0]["prestrain"] = 0.002
        doc["supports"] = doc["supports"][:1]
        doc["drives"] = [FAIRLEAD]
        o = DynamicOptions(dt=0.05, t_end=1.0, newton=TIGHT, sensors=SENSORS)
        paths = ["water.density", "water.current[0]", "water.lines.line.cd", "water.lines.line.ca",
                 "water.waves.height", "materials.steel.density"]
    elif case == "waves":
        doc["members"][0]["prestrain"] = 0.002
        doc["water"]["waves"]["phase"] = 0.3
        o = DynamicOptions(dt=0.05, t_end=1.0, newton=TIGHT, sensors=SENSORS)
        paths = ["water.density", "water.current[0]", "water.lines.line.cd", "water.lines.line.cd_axial",
                 "water.lines.line.ca", "water.waves.height", "water.waves.period", "water.waves.phase",
                 "scene.gravity[1]", "materials.steel.density", "sections.rope.diameter"]
    else:
        o = DynamicOptions(dt=0.05, t_end=1.0, newton=TIGHT, sensors=SENSORS, start="static",
                           loads=[{"member": "line", "at": 0.5, "force": [300.0, 0.0],
                                   "history": [[0.0, 0.0], [0.3, 1.0], [1.0, 1.0]]}])
        paths = ["water.density", "water.current[0]", "water.lines.line.cd", "water.lines.line.ca",
                 "materials.steel.density", "sections.rope.diameter"]
    fw = dynamic_sensitivity(doc, paths, o)
    g = dynamic_gradient(doc, paths, o, SensorOutput("mid", 0, "integral"))
    w = np.zeros(len(fw.t))
    w[:-1] += np.diff(fw.t) / 2
    w[1:] += np.diff(fw.t) / 2

    def record(d):
        r = simulate(scene_from_dict(d)[0], o)
        assert r.success and len(r.t) == len(fw.t), r.status
        return r.sensors["mid"]
    for p in paths:
        an = fw.sensor(p, "mid")
        ref = float(w @ an[:, 0])
        assert abs(g.gradient[p] - ref) <= 1e-8 * abs(ref), (p, "adjoint")
        assert _relative(an, richardson(record, doc, p)) <= 1e-5, (p, "forward")


def test_spatial_line_in_a_skew_current_and_oblique_waves():
    """The same line in 3D, its fairlead off the plane, a current across it (0.5, 0.3) m/s and waves travelling at 30
    deg: statics and a run (forward against differences, adjoint against forward)."""
    def spatial(d: dict) -> dict:
        d["scene"].update(dim=3, gravity=[0.0, 0.0, -9.81])
        d["members"][0]["points"] = [[0.0, 0.0, -20.0], [24.0, 3.0, -2.0]]
        d["water"]["current"] = [0.5, 0.3, 0.0]
        return d
    doc = spatial(mooring())
    scene, r = _solve(doc)
    s = StaticSensitivity(scene, r, doc)
    for p in ["water.current[1]", "water.lines.line.cd_axial", "water.density", "members[0].prestrain"]:
        assert _relative(s.dx(p), richardson(lambda d: _solve(d)[1].x, doc, p, rel=1e-2)) <= 1e-6, p
    doc = spatial(mooring(waves=True, ca_axial=1.0, elements=5))
    doc["members"][0]["prestrain"] = 0.002
    doc["water"]["waves"]["direction"] = 30.0
    o = DynamicOptions(dt=0.05, t_end=0.6, newton=TIGHT, sensors=SENSORS)
    paths = ["water.current[1]", "water.lines.line.ca", "water.waves.period", "water.density"]
    fw = dynamic_sensitivity(doc, paths, o)
    g = dynamic_gradient(doc, paths, o, SensorOutput("mid", 1, "end"))

    def record(d):
        rr = simulate(scene_from_dict(d)[0], o)
        assert rr.success, rr.status
        return rr.sensors["mid"]
    for p in paths:
        an = fw.sensor(p, "mid")
        assert abs(g.gradient[p] - an[-1, 1]) <= 1e-8 * abs(an[-1, 1]), (p, "adjoint")
        assert _relative(an, richardson(record, doc, p)) <= 1e-5, (p, "forward")


def test_calibrate_drag_coefficient_and_density_from_positions_in_a_current():
    """The calibration (Levenberg-Marquardt on the exact Jacobian) of a line's drag coefficient and its steel's
    density from 11 node positions with 1 mm noise, from 30 % and 10 % off: the estimate within 3 standard deviations
    of the truth (seeded noise: measured 1.2 and 1.1 sigma, 7 iterations)."""
    from ancf_sym.sensitivity.calibrate import Measurement, calibrate

    doc = mooring(elements=12)
    _, r = _solve(doc)
    nodes = r.assembly.member_coordinates(r.x, "line")[r.assembly.mesh.members["line"].public_nodes, :2]
    rng = np.random.default_rng(1)
    data = [Measurement("line", k, nodes[k] + rng.normal(0.0, 1e-3, 2)) for k in range(1, 12)]
    c = calibrate(doc, data, ["water.lines.line.cd", "materials.steel.density"], start=[0.8, 7000.0])
    assert c.converged and c.iterations <= 15
    assert np.all(np.abs(c.estimate - [1.2, 7800.0]) <= 3 * c.std), (c.estimate, c.std)


@pytest.mark.parametrize("case", ["dry", "wet"])
def test_dynamic_sensitivities_to_a_prestrain(case):
    """A line's prestrain (its length) in a run from its equilibrium (dry; in water in the current), pulled by a time
    load: the kernels' length derivative at every state and the wet points' lengths; the sensor at a node (a
    material coordinate would move in its element). Forward against differences, adjoint against forward, and the
    total energy at the end by the adjoint against differences."""
    from ancf_sym.sensitivity.adjoint import EnergyOutput

    doc = mooring(ca_axial=1.0, elements=5)
    if case == "dry":
        del doc["water"]
    sensors = [{"name": "node", "kind": "position", "member": "line", "at": 2}]
    o = DynamicOptions(dt=0.05, t_end=1.0, newton=TIGHT, sensors=sensors, start="static",
                       loads=[{"member": "line", "at": 2, "force": [300.0, 0.0],
                               "history": [[0.0, 0.0], [0.3, 1.0], [1.0, 1.0]]}])
    p = "members[0].prestrain"
    fw = dynamic_sensitivity(doc, [p], o)
    an = fw.sensor(p, "node")
    g = dynamic_gradient(doc, [p], o, SensorOutput("node", 1, "end"))
    assert abs(g.gradient[p] - an[-1, 1]) <= 1e-8 * abs(an[-1, 1])

    def record(d):
        rr = simulate(scene_from_dict(d)[0], o)
        assert rr.success, rr.status
        return rr.sensors["node"]
    assert _relative(an, richardson(record, doc, p)) <= 1e-5
    ge = dynamic_gradient(doc, [p], o, EnergyOutput("total"))
    fe = richardson(lambda d: dynamic_gradient(d, [], o, EnergyOutput("total")).value, doc, p)
    assert abs(ge.gradient[p] - fe) <= 1e-5 * abs(fe)


def test_refused_in_water_with_the_reason():
    doc = mooring(ca_axial=0.5)
    o = DynamicOptions(dt=0.05, t_end=0.2, sensors=SENSORS)
    with pytest.raises(SceneError, match="ca != ca_axial"):
        dynamic_sensitivity(doc, ["water.density"], o)
    for path, why in [("water.depth", "differentiable water numbers"),
                      ("scene.gravity[0]", "only its last component"),
                      ("water.current[1]", "vertical component")]:
        with pytest.raises(ValueError, match=why):
            sensitivities(doc, [path])
    profile = mooring()
    profile["water"]["current"] = [[-20.0, [0.3, 0.0]], [0.0, [0.8, 0.0]]]
    with pytest.raises(ValueError, match="not its height"):
        sensitivities(profile, ["water.current[0][0]"])
    with pytest.raises(SceneError, match="from the reference"):  # (the start's slopes move with the prestrain)
        dynamic_sensitivity(mooring(ca_axial=1.0), ["members[0].prestrain"], o)
    with pytest.raises(SceneError, match="sensor at the material coordinate"):  # (it moves in its element)
        dynamic_sensitivity(mooring(ca_axial=1.0), ["members[0].prestrain"],
                            DynamicOptions(dt=0.05, t_end=0.2, sensors=SENSORS, start="static"))
    waves = mooring(waves=True, ca_axial=1.0)
    with pytest.raises(SceneError, match="static start under waves"):
        dynamic_sensitivity(waves, ["water.density"], DynamicOptions(dt=0.05, t_end=0.2, start="static"))


def test_command_line_adds_water_sensitivities(tmp_path):
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "ancf_sym.cli", "run", str(SCENE), "--out", str(out), "--quiet", "--no-animation",
           "--sensitivity", "water.density", "--sensitivity", "water.current[0]"]
    subprocess.run(cmd, check=True, cwd=tmp_path, capture_output=True, timeout=300)
    data = json.loads((out / "result.json").read_text())
    import tomllib
    doc = tomllib.loads(SCENE.read_text())
    ref = sensitivities(doc, ["water.density", "water.current[0]"])
    for p in ("water.density", "water.current[0]"):
        got = data["sensitivities"][p]
        assert np.allclose(got["members"]["line"]["nodes"], ref[p]["members"]["line"]["nodes"], rtol=1e-8, atol=0)
        assert np.allclose(got["constraint_forces"]["pin line@end"], ref[p]["constraint_forces"]["pin line@end"],
                           rtol=1e-8)
