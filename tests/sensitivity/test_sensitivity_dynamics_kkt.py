"""Dynamic sensitivities through the KKT step: position drives (prescribed node motion, time-dependent rows),
rigid joints and a rigid body's rows (multipliers), an angle drive on the body, an applied torque (skew tangent),
forward against adjoint and against central differences of re-run scenes.

The forward and adjoint recursions solve the same differentiated KKT systems, one the transpose of the other:
they agree to the round-off of ~50 sparse QR solves (condition ~1e5 with the multiplier rows), far inside the 1e-8
asserted. Differences of runs: Newton to xtol = 1e-13 of the length, Richardson-extrapolated to remove the O(s^2)
truncation; the 1e-5 relative bound of the requirement."""
from __future__ import annotations

import numpy as np
import pytest

from ancf_sym.dynamics import DynamicOptions
from ancf_sym.dynamics.newton import NewtonOptions
from ancf_sym.sensitivity import get_parameter, with_parameter
from ancf_sym.sensitivity.adjoint import EnergyOutput, MultiplierOutput, SensorOutput, dynamic_gradient
from ancf_sym.sensitivity.dynamics import dynamic_sensitivity

TIGHT = NewtonOptions(xtol=1e-13, tol=1e-12, lte_fraction=0.0, single=False)
BASE = {"scene": {"name": "p", "dim": 2, "gravity": [0.0, -9.81]},
        "materials": {"m": {"E": 2e5, "density": 1200.0}}, "sections": {"s": {"area": 1e-4, "I": 2e-9}},
        "analysis": {"type": "dynamics", "dt": 2e-3, "t_end": 0.12}}
# a rope whose start is carried sideways (x = 20 t^2, a position drive: two time-dependent rows)
DRIVE = dict(BASE, members=[{"name": "rope", "points": [[0, 0], [1.0, 0]], "elements": 6, "material": "m",
                             "section": "s", "bending": True}],
             masses=[{"member": "rope", "at": "end", "mass": 0.05}],
             drives=[{"type": "position", "member": "rope", "at": "start", "position": [[[0.0, [0.0, 0.0, 20.0]]],
                                                                                       0.0]}],
             dampings=[{"type": "rayleigh", "alpha": 1.0}])
# an L frame (rigid joint, bilinear rows) pinned at its start, a rigid body pinned at its tip (unit-vector row)
JOINT = dict(BASE, members=[{"name": "a", "points": [[0, 0], [0.5, 0]], "elements": 3, "material": "m",
                             "section": "s", "bending": True},
                            {"name": "b", "points": [[0.5, 0], [0.5, -0.5]], "elements": 3, "material": "m",
                             "section": "s", "bending": True}],
             supports=[{"type": "pin", "member": "a", "at": "start"}],
             joints=[{"type": "rigid", "a": ["a", "end"], "b": ["b", "start"]}],
             bodies=[{"name": "tip", "mass": 0.05, "inertia": 1e-4, "position": [0.6, -0.5], "pin": [["b", "end"]]}])
# the frame with a torque tau = 0.05 t on its tip body (a time-dependent force with a skew tangent)
TORQUE = dict(JOINT, drives=[{"type": "torque", "body": "tip", "torque": [[0.0, [0.0, 0.05]]]}])
# the frame with its tip body's angle prescribed, theta = 10 t^2 (a bilinear row with time-dependent coefficients)
ANGLE = dict(JOINT, drives=[{"type": "angle", "body": "tip", "angle": [[0.0, [0.0, 0.0, 10.0]]]}])
SENSORS = {"drive": [{"name": "tip", "kind": "position", "member": "rope", "at": "end"}],
           "joint": [{"name": "tip", "kind": "position", "member": "b", "at": "end"}]}
SENSORS["torque"] = SENSORS["angle"] = SENSORS["joint"]
SCENES = {"drive": DRIVE, "joint": JOINT, "torque": TORQUE, "angle": ANGLE}
PATHS = {"drive": ["materials.m.E", "materials.m.density", "sections.s.I", "masses[0].mass", "scene.gravity[1]",
                   "dampings[0].alpha"],
         "joint": ["materials.m.E", "materials.m.density", "sections.s.I", "scene.gravity[1]"]}
PATHS["torque"] = PATHS["angle"] = PATHS["joint"]


def opts(which, integrator="generalized_alpha"):
    return DynamicOptions(dt=2e-3, t_end=0.12, integrator=integrator, newton=TIGHT, sensors=SENSORS[which])


def trapezoid(t):
    w = np.zeros(len(t))
    w[:-1] += np.diff(t) / 2
    w[1:] += np.diff(t) / 2
    return w


@pytest.mark.parametrize("which,integrator", [("drive", "generalized_alpha"), ("drive", "hht"),
                                              ("joint", "generalized_alpha"), ("joint", "newmark"),
                                              ("torque", "generalized_alpha"), ("angle", "hht")])
def test_kkt_adjoint_equals_forward(which, integrator):
    doc, o = SCENES[which], opts(which, integrator)
    fw = dynamic_sensitivity(doc, PATHS[which], o)
    assert fw.lam.shape[1] >= 2  # (the scene has multiplier rows: the KKT path is the one tested)
    for comp in (0, 1):
        g = dynamic_gradient(doc, PATHS[which], o, SensorOutput("tip", comp, "integral"))
        for p in PATHS[which]:
            ds = fw.sensor(p, "tip")[:, comp]
            ref = trapezoid(fw.t) @ ds
            # (the solves' round-off is relative to the size of the state's sensitivity, max_i |dx_i/dp| per
            # step: an output nearly insensitive to p, the tip's x to gravity, keeps that round-off)
            scale = trapezoid(fw.t) @ np.max(np.abs(fw.dx[p]), axis=1)
            assert abs(g.gradient[p] - ref) <= 1e-8 * max(abs(ref), scale), (which, comp, p)


def richardson(f, doc, path):
    v = get_parameter(doc, path)
    s = 1e-3 * abs(v)

    def D(h):
        return (f(with_parameter(doc, path, v + h)) - f(with_parameter(doc, path, v - h))) / (2 * h)
    return (4 * D(s / 2) - D(s)) / 3


@pytest.mark.parametrize("which,out", [("drive", SensorOutput("tip", 1, "integral")),
                                       ("drive", EnergyOutput("kinetic")),
                                       ("joint", SensorOutput("tip", 1, "integral")),
                                       ("joint", EnergyOutput("kinetic")),
                                       ("torque", SensorOutput("tip", 1, "integral")),
                                       ("angle", SensorOutput("tip", 1, "integral"))],
                         ids=["drive_tip", "drive_kinetic", "joint_tip", "joint_kinetic", "torque_tip", "angle_tip"])
def test_kkt_adjoint_matches_central_differences(which, out):
    doc, o = SCENES[which], opts(which)
    paths = ["materials.m.E", "materials.m.density", "sections.s.I"]
    g = dynamic_gradient(doc, paths, o, out)
    for p in paths:
        fd = richardson(lambda d: dynamic_gradient(d, [], o, out).value, doc, p)
        assert abs(g.gradient[p] - fd) <= 1e-5 * abs(fd), (which, p, g.gradient[p], fd)


def test_multiplier_sensitivities_match_differences():
    """d lam / dp (the drive's reactions) at the end of the run against differences of the runs' multipliers."""
    doc, o = DRIVE, opts("drive")
    p = "materials.m.density"
    fw = dynamic_sensitivity(doc, [p], o)
    assert np.max(np.abs(fw.dlam[p][-1])) > 0.0
    v = get_parameter(doc, p)

    def lam(d):
        return dynamic_sensitivity(d, [], o).lam[-1]
    s = 1e-3 * v
    D = [(lam(with_parameter(doc, p, v + h)) - lam(with_parameter(doc, p, v - h))) / (2 * h) for h in (s, s / 2)]
    fd = (4 * D[1] - D[0]) / 3
    assert np.max(np.abs(fw.dlam[p][-1] - fd)) <= 1e-5 * np.max(np.abs(fd))


@pytest.mark.parametrize("which", ["drive", "angle"])
def test_multiplier_output_adjoint_equals_forward(which):
    """The adjoint gradient of a reaction's time integral and end value (MultiplierOutput: the drive's rows are
    last) against the forward d lam / dp (checked against differences above)."""
    doc, o = SCENES[which], opts(which)
    fw = dynamic_sensitivity(doc, PATHS[which], o)
    row = fw.lam.shape[1] - 1
    for reduce in ("integral", "end"):
        g = dynamic_gradient(doc, PATHS[which], o, MultiplierOutput(row, reduce))
        w = trapezoid(fw.t) if reduce == "integral" else np.eye(len(fw.t))[-1]
        assert abs(g.value - w @ fw.lam[:, row]) <= 1e-12 * np.max(np.abs(fw.lam[:, row]))
        for p in PATHS[which]:
            ref = w @ fw.dlam[p][:, row]
            scale = w @ np.max(np.abs(fw.dlam[p]), axis=1)  # (round-off relative to the multipliers' sensitivity)
            assert abs(g.gradient[p] - ref) <= 1e-8 * max(abs(ref), scale), (which, reduce, p, g.gradient[p], ref)
