"""Dynamic sensitivities of runs with contact damping and regularised Coulomb friction (forward and discrete
adjoint) against central differences of re-run scenes, with the contact's mu, damping and normal-law stiffness as
parameters.

The runs solve each step by Newton to xtol = 1e-13 of the length (lte_fraction 0), so differences of runs differ from
the discrete solution's by ~1e-13 / h (h = 1e-3 of the value), far below the issue's 1e-5 for dynamic derivatives;
Richardson extrapolation removes the O(h^2) truncation. Both scenes keep every contact point pressed from the first
step on (they start slightly inside the surface, at about the penetration their load holds), so the step map is smooth
along the run and differences of runs converge: the notes say so. The adjoint and the forward recursion solve the same
linear equations, one the transpose of the other: they agree to the round-off of ~100 sparse solves, far inside the
1e-8 asserted. A missing term errs far beyond 1e-5: without the contact dissipation's tangents d f/dq, d f/dv in
the differentiated step the records' derivatives err by 4 % (mu, ground) to 80x (the ground's stiffness); without
its parameter forcing the derivative with respect to mu or the damping is zero."""
from __future__ import annotations

import copy
import json
import math
import re

import numpy as np
import pytest

from ancf_sym.dynamics import DynamicOptions
from ancf_sym.dynamics.newton import NewtonOptions
from ancf_sym.scene import SceneError
from ancf_sym.sensitivity import get_parameter, sensitivities, with_parameter
from ancf_sym.sensitivity.adjoint import SensorOutput, dynamic_gradient
from ancf_sym.sensitivity.dynamics import dynamic_sensitivity
from ancf_sym.sensitivity.model_derivative import ParameterError

TIGHT = NewtonOptions(xtol=1e-13, tol=1e-12, lte_fraction=0.0, single=False)

# A 1 m rope (4 elements) lying on a penalty ground, held back by a soft spring (a weightless cable pinned 0.5 m behind
# it) and pulled along by 0.6 N at its end: it slides against regularised Coulomb friction (mu = 0.3, mu m g = 0.35 N;
# slip speeds up to 0.3 m/s against eps = 0.02 m/s), its contact damped. Weight 1.18 N/m on k = 1e4 N/m^2: 0.12 mm
# deep at rest; it starts 0.18 mm deep, so the bounce never lifts a point.
GROUND = {"scene": {"name": "slide", "dim": 2, "gravity": [0.0, -9.81]},
          "materials": {"m": {"E": 5e6, "density": 1200.0}, "soft": {"E": 2.5e4, "density": 100.0}},
          "sections": {"s": {"area": 1e-4, "I": 1e-9}, "w": {"area": 1e-4}},
          "members": [{"name": "rope", "points": [[0, 0], [1.0, 0]], "elements": 4, "material": "m", "section": "s",
                       "bending": True},
                      {"name": "spring", "points": [[-0.5, 0], [0, 0]], "elements": 1, "material": "soft",
                       "section": "w", "bending": False, "gravity": False}],
          "supports": [{"type": "pin", "member": "spring", "at": "start"}],
          "joints": [{"type": "hinge", "a": ["spring", "end"], "b": ["rope", "start"]}],
          "loads": [{"type": "force", "member": "rope", "at": "end", "value": [0.6, 0.0]}],
          "contacts": [{"type": "ground", "member": "rope", "level": 1.8e-4, "stiffness": 1e4, "thickness": 0.0,
                        "damping": 2e5, "mu": 0.3, "eps": 0.02}]}

# Capstan-like: a rope (8 elements, EA = 1e4 N) wrapped half round a drum (R = 0.1 m, Hertz law, damped, mu = 0.2),
# 0.5 kg at each end; the light end held by a prestrained spring (9.1 N), the heavy end pulled by 18 N > 9.1 N
# e^(mu pi) = 17 N: the rope slides over the drum. The arc starts 0.4 mm inside the drum, about the penetration its
# tension holds.
R = 0.1
DRUM = {"scene": {"name": "capstan", "dim": 2, "gravity": [0.0, 0.0]},
        "materials": {"m": {"E": 1e8, "density": 1000.0}, "soft": {"E": 1e7, "density": 100.0}},
        "sections": {"s": {"area": 1e-4}, "w": {"area": 1e-5}},
        "members": [{"name": "rope", "arc": {"centre": [0.0, 0.0], "radius": R - 4e-4, "angle0": math.pi,
                                             "sweep": -math.pi}, "elements": 8, "material": "m", "section": "s",
                     "bending": False},
                    {"name": "spring", "points": [[-(R - 4e-4), -0.5], [-(R - 4e-4), 0.0]], "elements": 1,
                     "material": "soft", "section": "w", "bending": False, "prestrain": 0.1}],
        "supports": [{"type": "pin", "member": "spring", "at": "start"}],
        "joints": [{"type": "hinge", "a": ["spring", "end"], "b": ["rope", "start"]}],
        "loads": [{"type": "force", "member": "rope", "at": "end", "value": [0.0, -18.0]}],
        "masses": [{"member": "rope", "at": "start", "mass": 0.5}, {"member": "rope", "at": "end", "mass": 0.5}],
        "contacts": [{"type": "circle", "member": "rope", "centre": [0.0, 0.0], "radius": R, "hertz": 1e7,
                      "thickness": 0.0, "damping": 8e5, "mu": 0.2, "eps": 0.01}]}

# The same rope over a pulley: the drum carried by a rigid body on a revolute joint (0.005 kg m^2), which the friction
# spins (the body's rows with multipliers: a KKT step; the kernel's inputs hold the body's coordinates and rates).
PULLEY = copy.deepcopy(DRUM)
PULLEY["bodies"] = [{"name": "p", "mass": 1.0, "inertia": 0.005, "position": [0.0, 0.0], "revolute": [0.0, 0.0]}]
del PULLEY["contacts"][0]["centre"]
PULLEY["contacts"][0]["body"] = "p"

# The ground rope in space (cable3d), pulled obliquely: friction against the slip's direction in the plane.
GROUND3D = copy.deepcopy(GROUND)
GROUND3D["scene"].update(dim=3, gravity=[0.0, 0.0, -9.81])
GROUND3D["members"][0]["points"] = [[0, 0, 0], [1.0, 0, 0]]
GROUND3D["members"][1]["points"] = [[-0.5, 0, 0], [0, 0, 0]]
GROUND3D["loads"][0]["value"] = [0.6, 0.3, 0.0]

CASES = {  # scene, options, sensor member and place, its component, paths
    "ground": (GROUND, dict(dt=2e-3, t_end=0.2), "rope", "end", 0,
               ["contacts[0].mu", "contacts[0].stiffness", "contacts[0].damping", "materials.m.E"]),
    "ground3d": (GROUND3D, dict(dt=2e-3, t_end=0.2), "rope", "end", 1,
                 ["contacts[0].mu", "contacts[0].stiffness", "contacts[0].damping"]),
    "drum": (DRUM, dict(dt=1e-3, t_end=0.05), "rope", "end", 1,
             ["contacts[0].mu", "contacts[0].hertz", "contacts[0].damping", "loads[0].value[1]"]),
    "pulley": (PULLEY, dict(dt=1e-3, t_end=0.05), "rope", "end", 1,
               ["contacts[0].mu", "contacts[0].hertz", "contacts[0].damping"]),
}


def options(case: str, integrator: str = "generalized_alpha") -> DynamicOptions:
    _, kw, member, at, _, _ = CASES[case]
    return DynamicOptions(integrator=integrator, newton=TIGHT, sensors=[{"name": "s", "kind": "position",
                                                                         "member": member, "at": at}], **kw)


def record(doc, o, component):
    r = dynamic_sensitivity(doc, [], o)
    ev = r.sensors[0]
    return np.array([ev(x, v)[component] for x, v in zip(r.x, r.v)])


def richardson(f, doc, path):
    v = get_parameter(doc, path)
    h = 1e-3 * abs(v)

    def D(s):
        return (f(with_parameter(doc, path, v + s)) - f(with_parameter(doc, path, v - s))) / (2 * s)
    return (4 * D(h / 2) - D(h)) / 3


@pytest.mark.parametrize("case", list(CASES))
def test_forward_and_adjoint_match_central_differences(case):
    doc, _, _, _, comp, paths = CASES[case]
    o = options(case)
    fw = dynamic_sensitivity(doc, paths, o)
    # the run is smooth in p: every contact point pressed after the first step (else the differences would not be)
    assert any("no contact point touches down or lifts off" in n for n in fw.notes), fw.notes
    assert any("regularised Coulomb law" in n for n in fw.notes), fw.notes
    out = SensorOutput("s", comp, "integral")
    g = dynamic_gradient(doc, paths, o, out)
    w = np.zeros(len(fw.t))
    w[:-1] += np.diff(fw.t) / 2
    w[1:] += np.diff(fw.t) / 2
    for p in paths:
        got = fw.sensor(p, "s")[:, comp]
        fd = richardson(lambda d: record(d, o, comp), doc, p)
        assert np.linalg.norm(got - fd) <= 1e-5 * np.linalg.norm(fd), p
        ref = w @ got
        assert abs(g.gradient[p] - ref) <= 1e-8 * abs(ref), p
    # physics: more friction holds the rope back (the ground rope's end slides less far along the pull; over the
    # drum and the pulley (whose inertia the friction must spin up) the heavy end descends less: its height's
    # integral rises)
    assert g.gradient["contacts[0].mu"] * (-1 if case.startswith("ground") else 1) > 0


@pytest.mark.parametrize("integrator", ["newmark", "hht"])
def test_other_schemes(integrator):
    doc, _, _, _, comp, paths = CASES["ground"]
    o = options("ground", integrator)
    fw = dynamic_sensitivity(doc, paths, o)
    out = SensorOutput("s", comp, "end")
    g = dynamic_gradient(doc, paths, o, out)
    for p in paths:
        ref = fw.sensor(p, "s")[-1, comp]
        assert abs(g.gradient[p] - ref) <= 1e-8 * abs(ref), p
    got = fw.sensor("contacts[0].mu", "s")[:, comp]
    fd = richardson(lambda d: record(d, o, comp), doc, "contacts[0].mu")
    assert np.linalg.norm(got - fd) <= 1e-5 * np.linalg.norm(fd)


def test_touch_down_named_in_the_notes():
    """The ground rope tilted (its end 2 cm up) and dropped from 1 mm above the ground: its contact points touch down
    one after another, where the penetration's kink makes the derivative one-sided: named by step, forward and
    adjoint alike. By contact point, not by element: an element whose first points already touch is no event for
    the element-wise note, so the points' note names more steps. The first touch-down: the start falls 1 mm in
    sqrt(2 h / g) = 14 ms (held by neither the slack spring nor the rope's bending), named at a step end after it."""
    doc = copy.deepcopy(GROUND)
    doc["contacts"][0]["level"] = -1e-3
    doc["members"][0]["points"] = [[0, 0], [1.0, 0.02]]
    o = options("ground")
    fw = dynamic_sensitivity(doc, ["contacts[0].mu"], o)
    by_point = [n for n in fw.notes if "contact points touch down or lift off in" in n]
    by_element = [n for n in fw.notes if n.startswith("contacts open or close in")]
    assert len(by_point) == 1 and len(by_element) == 1, fw.notes
    steps = [int(re.search(r"in (\d+) step", n).group(1)) for n in (by_point[0], by_element[0])]
    assert steps[0] > steps[1] >= 1, fw.notes
    first = float(re.search(r"first at t = ([0-9.e-]+) s", by_point[0]).group(1))
    assert math.sqrt(2 * 1e-3 / 9.81) <= first <= 0.05, by_point[0]
    g = dynamic_gradient(doc, ["contacts[0].mu"], o, SensorOutput("s", 0, "end"))
    assert g.notes == fw.notes


def test_statics_refuses_friction_and_damping_by_name():
    """A static equilibrium does not depend on mu or the contact damping (zero at rest): refused by name rather
    than answered with a zero a calibration could not use; eps (nonlinear) refused in dynamics too."""
    doc = copy.deepcopy(GROUND)
    doc["supports"].append({"type": "pin", "member": "rope", "at": "end"})
    for p in ("contacts[0].mu", "contacts[0].damping"):
        with pytest.raises(ParameterError, match=r"act on velocities only"):
            sensitivities(doc, [p])
    with pytest.raises(ParameterError, match=r"contacts\[0\].eps.*regularisation"):
        dynamic_sensitivity(GROUND, ["contacts[0].eps"], options("ground"))
    bad = copy.deepcopy(GROUND)
    bad["contacts"][0]["method"] = "exact"
    with pytest.raises((SceneError, ValueError)):
        dynamic_sensitivity(bad, ["contacts[0].mu"], options("ground"))


def test_cli_run_with_friction_sensitivity(tmp_path):
    """`ancf-sym run SCENE --sensitivity contacts[0].mu` on a dynamics scene with friction: the sensors'
    derivatives at the output times (those of the Python forward sensitivities) and the notes."""
    from ancf_sym.cli import main

    lines = ['[scene]', 'name = "slide"', 'dim = 2', 'gravity = [0.0, -9.81]',
             '[materials.m]', 'E = 5e6', 'density = 1200.0', '[materials.soft]', 'E = 2.5e4', 'density = 100.0',
             '[sections.s]', 'area = 1e-4', 'I = 1e-9', '[sections.w]', 'area = 1e-4']
    for m in GROUND["members"]:
        lines += ['[[members]]'] + [f'{k} = {json.dumps(v)}' for k, v in m.items()]
    for table in ("supports", "joints", "loads", "contacts"):
        for d in GROUND[table]:
            lines += [f'[[{table}]]'] + [f'{k} = {json.dumps(v)}' for k, v in d.items()]
    lines += ['[analysis]', 'type = "dynamics"', 'dt = 2e-3', 't_end = 0.1', 'output_dt = 0.01',
              'sensors = [{ name = "tip", kind = "position", member = "rope", at = "end" }]']
    scene = tmp_path / "slide.toml"
    scene.write_text("\n".join(lines) + "\n")
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out), "--quiet", "--no-animation",
                 "--sensitivity", "contacts[0].mu"]) == 0
    data = json.loads((out / "result.json").read_text())
    got = data["sensitivities"]["contacts[0].mu"]
    assert got["t"] == data["t"] and len(got["t"]) == 11
    d = np.asarray(got["sensors"]["tip"])
    assert d.shape == np.asarray(data["sensors"]["tip"]).shape
    assert any("regularised Coulomb law" in n for n in got["notes"])
    o = DynamicOptions(dt=2e-3, t_end=0.1, sensors=[{"name": "tip", "kind": "position", "member": "rope",
                                                     "at": "end"}])
    ref = dynamic_sensitivity(GROUND, ["contacts[0].mu"], o).sensor("contacts[0].mu", "tip")[::5]
    assert np.allclose(d, ref, rtol=1e-9, atol=1e-12 * np.abs(ref).max())
    assert np.all(d[1:, 0] < 0)  # (more friction: the tip slides less far)


def test_calibrate_friction_and_damping_to_a_sensor_history():
    """mu and the contact damping of the sliding rope fitted to its tip's record with 10 um noise, from 33 % and
    50 % off: the estimates within 4 standard deviations (from the exact Jacobian and the residual noise) of the
    truth (a Gaussian miss beyond 4 sigma has probability 6e-5), mu to better than 1e-3."""
    from ancf_sym.sensitivity.calibrate_history import SensorHistory, calibrate_history

    o = DynamicOptions(dt=2e-3, t_end=0.2, sensors=[{"name": "tip", "kind": "position", "member": "rope",
                                                     "at": "end"}])
    truth = record(GROUND, o, 0)
    noise = 1e-5 * np.random.default_rng(1).standard_normal(len(truth))
    data = SensorHistory(2e-3 * np.arange(len(truth)), {("tip", 0): truth + noise})
    start = with_parameter(with_parameter(GROUND, "contacts[0].mu", 0.2), "contacts[0].damping", 1e5)
    paths = ["contacts[0].mu", "contacts[0].damping"]
    c = calibrate_history(start, data, paths, options=o)
    assert c.converged, c.summary()
    for k, true in enumerate((0.3, 2e5)):
        assert abs(c.estimate[k] - true) <= 4 * c.std[k], (paths[k], c.summary())
    assert abs(c.estimate[0] - 0.3) <= 3e-4
