"""Dynamic sensitivities of the curvature and body sensors (chain rule on dx, dv: ancf_sym.sensitivity.
sensor_jacobian): the forward records against Richardson-extrapolated central differences of re-run scenes, and
the adjoint of their reductions against the forward records.

A planar rope with a tip mass (curvature |r_x x r_xx| / |r_x|^3 at a point), a planar pendulum body (x, y, angle,
angular velocity) and a spatial body on a tilted revolute joint held by a bending rope (centre, world angular
velocity, axes; the rope's 3D curvature). Tolerances: 1e-5 relative to the record's scale (the requirement; runs
converged to xtol = 1e-13 of the length, differences' truncation O(h^4) at h = 1e-2 of the value: ~1e-8; a step
of 1e-3 would meet the runs' round-off); forward
= adjoint to 1e-8 (the same solves transposed). A missing chain-rule term (the 1/|r_x|^3 factor's derivative, the
omega's dv part) errs by O(1e-1..1)."""
from __future__ import annotations

import numpy as np
import pytest

from ancf_sym.dynamics import DynamicOptions
from ancf_sym.dynamics.newton import NewtonOptions
from ancf_sym.sensitivity import get_parameter, with_parameter
from ancf_sym.sensitivity.adjoint import SensorOutput, dynamic_gradient
from ancf_sym.sensitivity.dynamics import dynamic_sensitivity

TIGHT = NewtonOptions(xtol=1e-13, tol=1e-12, lte_fraction=0.0, single=False)
ROPE = {"scene": {"name": "p", "dim": 2, "gravity": [0.0, -9.81]},
        "materials": {"m": {"E": 5e6, "density": 1200.0}}, "sections": {"s": {"area": 1e-4, "I": 1e-9}},
        "members": [{"name": "rope", "points": [[0, 0], [1.0, 0]], "elements": 4, "material": "m", "section": "s",
                     "bending": True}],
        "supports": [{"type": "clamp", "member": "rope", "at": "start"}],
        "masses": [{"member": "rope", "at": "end", "mass": 0.05}]}
PLANAR = {"scene": {"name": "body", "dim": 2, "gravity": [0.0, -9.81]},
          "materials": {"m": {"E": 1e7, "density": 1500.0}}, "sections": {"s": {"area": 1e-4, "I": 1e-9}},
          "members": [{"name": "rope", "points": [[0, 0], [1.0, -1.0]], "elements": 4, "material": "m",
                       "section": "s", "bending": True}],
          "supports": [{"type": "pin", "member": "rope", "at": "start"}],
          "bodies": [{"name": "tip", "mass": 0.5, "inertia": 0.02, "position": [1.2, -1.0], "pin": [["rope", "end"]],
                      "revolute": [1.5, -1.0]}]}
INERTIA = [[0.030, 0.002, -0.001], [0.002, 0.025, 0.003], [-0.001, 0.003, 0.040]]
PLATE = {"scene": {"name": "plate", "dim": 3, "gravity": [0.0, 0.0, -9.81]},
         "materials": {"m": {"E": 2e7, "density": 1500.0}}, "sections": {"s": {"area": 1e-4, "I": 1e-9}},
         "members": [{"name": "rope", "points": [[0.6, 0.0, 0.0], [0.6, 0.1, 1.0]], "elements": 3, "material": "m",
                      "section": "s", "element": "cable3d", "bending": True}],
         "supports": [{"type": "pin", "member": "rope", "at": "end"}],
         "bodies": [{"name": "plate", "mass": 2.0, "inertia": INERTIA, "position": [0.3, 0.0, -0.05],
                     "force": [0.5, 1.0, 0.0], "revolute": {"point": [0.0, 0.0, 0.0], "axis": [0.3, 1.0, 0.4]},
                     "pin": [["rope", "start"]]}]}
CASES = {"rope_curvature": (ROPE, [{"name": "k", "kind": "curvature", "member": "rope", "at": 0.3}],
                            ["materials.m.E", "masses[0].mass"]),
         "planar_body": (PLANAR, [{"name": "b", "kind": "body", "member": "tip"}],
                         ["bodies[0].inertia", "bodies[0].mass"]),
         "spatial_body": (PLATE, [{"name": "b", "kind": "body", "member": "plate"},
                                  {"name": "k", "kind": "curvature", "member": "rope", "at": 0.5}],
                          ["bodies[0].mass", "bodies[0].inertia[1][1]"])}


def opts(sensors):
    return DynamicOptions(dt=2e-3, t_end=0.04, newton=TIGHT, sensors=sensors)


def records(doc, o):
    r = dynamic_sensitivity(doc, [], o)
    return {ev.sensor.name: np.array([ev(x, v) for x, v in zip(r.x, r.v)]) for ev in r.sensors}


def richardson(f, doc, path, rel=1e-2):
    v = get_parameter(doc, path)
    s = rel * abs(v)

    def D(h):
        a, b = f(with_parameter(doc, path, v + h)), f(with_parameter(doc, path, v - h))
        return {k: (a[k] - b[k]) / (2 * h) for k in a}
    d1, d2 = D(s), D(s / 2)
    return {k: (4 * d2[k] - d1[k]) / 3 for k in d1}


@pytest.mark.parametrize("case", list(CASES))
def test_sensor_records_match_central_differences(case):
    doc, sensors, paths = CASES[case]
    o = opts(sensors)
    fw = dynamic_sensitivity(doc, paths, o)
    for p in paths:
        fd = richardson(lambda d: records(d, o), doc, p)
        for name, ref in fd.items():
            got = fw.sensor(p, name)
            scale = np.abs(ref).max(axis=0)  # (per component: its largest change over the run)
            scale[scale == 0] = 1.0
            assert np.all(np.abs(got - ref) <= 1e-5 * scale), (case, p, name, np.abs(got - ref).max(axis=0), scale)


@pytest.mark.parametrize("case", list(CASES))
def test_adjoint_equals_forward(case):
    doc, sensors, paths = CASES[case]
    o = opts(sensors)
    fw = dynamic_sensitivity(doc, paths, o)
    w = np.zeros(len(fw.t))
    w[:-1] += np.diff(fw.t) / 2
    w[1:] += np.diff(fw.t) / 2
    for s in sensors:
        k = 1 if s["kind"] == "curvature" else 15 if doc is PLATE else 4
        for c in range(k):
            g = dynamic_gradient(doc, paths, o, SensorOutput(s["name"], c, "integral"))
            for p in paths:
                ref = w @ fw.sensor(p, s["name"])[:, c]
                assert abs(g.gradient[p] - ref) <= 1e-8 * max(abs(ref), 1e-12), (case, s["name"], c, p)
