"""Discrete adjoint of a dynamic run (ancf_sym.sensitivity.adjoint) against the forward sensitivities and against
central differences of runs, with Rayleigh mass damping and its coefficient as a parameter.

The adjoint and the forward recursion solve the same linear equations of the differentiated scheme, one the
transpose of the other: they agree to the round-off of ~100 sparse solves (condition ~1e4 here), far inside the
1e-8 asserted. Differences of runs: Newton to xtol = 1e-13 of the length (as the forward tests), Richardson-
extrapolated to remove the O(s^2) truncation; the issue's 1e-5 relative bound. A missing term (the damping's, the
initial acceleration's, the alpha history's) errs by O(1e-2..1)."""
from __future__ import annotations

import copy

import numpy as np
import pytest

from ancf_sym.dynamics import DynamicOptions
from ancf_sym.dynamics.newton import NewtonOptions
from ancf_sym.scene import SceneError
from ancf_sym.sensitivity import get_parameter, with_parameter
from ancf_sym.sensitivity.adjoint import EnergyOutput, SensorOutput, dynamic_gradient
from ancf_sym.sensitivity.dynamics import dynamic_sensitivity

DOC = {"scene": {"name": "p", "dim": 2, "gravity": [0.0, -9.81]},
       "materials": {"m": {"E": 5e6, "density": 1200.0}}, "sections": {"s": {"area": 1e-4, "I": 1e-9}},
       "members": [{"name": "rope", "points": [[0, 0], [1.0, 0]], "elements": 6, "material": "m", "section": "s",
                    "bending": True}],
       "supports": [{"type": "pin", "member": "rope", "at": "start"}],
       "loads": [{"type": "force", "member": "rope", "at": "end", "value": [0.0, -0.5]}],
       "masses": [{"member": "rope", "at": "end", "mass": 0.05}],
       "dampings": [{"type": "rayleigh", "alpha": 2.0}]}
TIGHT = NewtonOptions(xtol=1e-13, tol=1e-12, lte_fraction=0.0, single=False)
PATHS = ["materials.m.E", "scene.gravity[1]", "sections.s.I", "masses[0].mass", "loads[0].value[1]",
         "materials.m.density", "dampings[0].alpha"]
SENSORS = [{"name": "tip", "kind": "position", "member": "rope", "at": "end"},
           {"name": "mid_v", "kind": "velocity", "member": "rope", "at": 3},
           {"name": "stretch", "kind": "strain", "member": "rope", "at": 0.25}]
OUTPUTS = [SensorOutput("tip", 1, "integral"), SensorOutput("mid_v", 0, "end"), SensorOutput("stretch", 0, "sum")]


def opts(integrator="generalized_alpha", **kw):
    return DynamicOptions(dt=2e-3, t_end=0.2, integrator=integrator, newton=TIGHT, sensors=SENSORS, **kw)


def weights(out, t):
    w = np.zeros(len(t))
    if out.reduce == "integral":
        w[:-1] += np.diff(t) / 2
        w[1:] += np.diff(t) / 2
    elif out.reduce == "sum":
        w[:] = 1.0
    else:
        w[-1] = 1.0
    return w


@pytest.mark.parametrize("integrator", ["generalized_alpha", "newmark", "hht"])
def test_adjoint_equals_forward_sensitivities(integrator):
    o = opts(integrator)
    fw = dynamic_sensitivity(DOC, PATHS, o)
    for out in OUTPUTS:
        g = dynamic_gradient(DOC, PATHS, o, out)
        for p in PATHS:
            ref = weights(out, fw.t) @ fw.sensor(p, out.sensor)[:, out.component]
            assert abs(g.gradient[p] - ref) <= 1e-8 * abs(ref), (out, p)


def richardson(f, doc, path):
    v = get_parameter(doc, path)
    s = 1e-3 * abs(v)

    def D(h):
        return (f(with_parameter(doc, path, v + h)) - f(with_parameter(doc, path, v - h))) / (2 * h)
    return (4 * D(s / 2) - D(s)) / 3


@pytest.mark.parametrize("out", [OUTPUTS[0], EnergyOutput("kinetic"), EnergyOutput("potential"), EnergyOutput("total")],
                         ids=["tip_integral", "kinetic_end", "potential_end", "total_end"])
def test_adjoint_matches_central_differences(out):
    o = opts()
    paths = ["materials.m.E", "materials.m.density", "dampings[0].alpha", "loads[0].value[1]"]
    g = dynamic_gradient(DOC, paths, o, out)
    for p in paths:
        fd = richardson(lambda d: dynamic_gradient(d, [], o, out).value, DOC, p)
        assert abs(g.gradient[p] - fd) <= 1e-5 * abs(fd), p


def test_static_start_newmark_least_squares():
    """From the static equilibrium (the statics' adjoint closes the sweep), a least-squares output of the record."""
    doc = copy.deepcopy(DOC)
    doc["supports"].append({"type": "pin", "member": "rope", "at": "end"})
    doc["loads"][0]["value"] = [0.3, -0.5]
    o = opts("newmark", start="static")
    data = np.linspace(0.0, 1e-3, 101)
    out = SensorOutput("stretch", 0, "least_squares", data)
    paths = ["scene.gravity[1]", "materials.m.E"]
    g = dynamic_gradient(doc, paths, o, out)
    for p in paths:
        fd = richardson(lambda d: dynamic_gradient(d, [], o, out).value, doc, p)
        assert abs(g.gradient[p] - fd) <= 1e-5 * abs(fd), p


@pytest.mark.parametrize("integrator", ["generalized_alpha", "newmark"])
def test_strain_rate_damping(integrator):
    """Kelvin-Voigt strain-rate damping (its exact tangents d f_d/dq, d f_d/dv in the step's, QR solves) with its
    coefficients as parameters, beside Rayleigh mass damping: adjoint = forward = Richardson differences."""
    doc = copy.deepcopy(DOC)
    doc["dampings"].append({"type": "strain_rate", "axial": 2.0, "bending": 2e-4})  # (axial: tau = c / EA = 4 ms)
    o = opts(integrator)
    out = SensorOutput("tip", 1, "integral")
    paths = ["dampings[1].axial", "dampings[1].bending", "materials.m.E", "dampings[0].alpha"]
    g = dynamic_gradient(doc, paths, o, out)
    fw = dynamic_sensitivity(doc, paths, o)
    for p in paths:
        ref = weights(out, fw.t) @ fw.sensor(p, "tip")[:, 1]
        assert abs(g.gradient[p] - ref) <= 1e-8 * abs(ref), p
    for p in paths[:2]:  # (E and alpha: checked against differences above)
        fd = richardson(lambda d: dynamic_gradient(d, [], o, out).value, doc, p)
        assert abs(g.gradient[p] - fd) <= 1e-5 * abs(fd), p


def test_bad_paths_and_outputs_refused_before_any_step():
    with pytest.raises(KeyError, match=r"dampings\[0\].beta names nothing"):
        dynamic_gradient(DOC, ["dampings[0].beta"], opts(), OUTPUTS[0])
    doc = copy.deepcopy(DOC)
    doc["dampings"][0]["beta"] = 0.0  # (zero: no stiffness damping in the run, but not a parameter here)
    with pytest.raises(SceneError, match=r"dampings\[0\].beta"):
        dynamic_gradient(doc, ["dampings[0].beta"], opts(), OUTPUTS[0])
    with pytest.raises(KeyError, match="nope"):
        dynamic_gradient(DOC, ["materials.m.E"], opts(), SensorOutput("nope"))


def test_time_loads_applied_as_the_run_applies_them():
    """A sideways force pulse (analysis.loads): the states are the package run's, the derivative its."""
    from ancf_sym.dynamics import simulate
    from ancf_sym.io.scene_toml import scene_from_dict

    pulse = [{"member": "rope", "at": "end", "force": [0.4, 0.0], "history": [[0.0, 0.0], [0.05, 1.0], [0.1, 0.0]]}]
    o = opts(loads=pulse)
    out = SensorOutput("tip", 0, "integral")
    paths = ["materials.m.E", "dampings[0].alpha"]
    g = dynamic_gradient(DOC, paths, o, out)
    run = simulate(scene_from_dict(DOC)[0], o)
    assert np.allclose(run.x, g.x[-1], rtol=0, atol=1e-10)
    fw = dynamic_sensitivity(DOC, paths, o)
    for p in paths:
        fd = richardson(lambda d: dynamic_gradient(d, [], o, out).value, DOC, p)
        assert abs(g.gradient[p] - fd) <= 1e-5 * abs(fd), p
        ref = weights(out, fw.t) @ fw.sensor(p, "tip")[:, 0]
        assert abs(g.gradient[p] - ref) <= 1e-8 * abs(ref), p


def test_contact_events_are_named():
    """The rope swings onto a penalty ground: the steps where contacts open or close are named in the notes (the
    force's kink at zero gap: one-sided derivatives there); forward and adjoint still agree (the same linear
    equations), and before the first touch there is no event to name."""
    doc = copy.deepcopy(DOC)
    doc["contacts"] = [{"type": "ground", "member": "rope", "level": -0.5, "stiffness": 1e4, "thickness": 0.0}]
    o = DynamicOptions(dt=2e-3, t_end=0.4, newton=TIGHT, sensors=SENSORS)
    paths = ["materials.m.E", "contacts[0].stiffness"]
    g = dynamic_gradient(doc, paths, o, OUTPUTS[0])
    assert len(g.notes) == 1 and "open or close" in g.notes[0]
    fw = dynamic_sensitivity(doc, paths, o)
    assert fw.notes == g.notes
    for p in paths:
        ref = weights(OUTPUTS[0], fw.t) @ fw.sensor(p, "tip")[:, 1]
        assert abs(g.gradient[p] - ref) <= 1e-8 * abs(ref), p
    early = dynamic_gradient(doc, paths, opts(), OUTPUTS[0])  # (0.2 s: the rope has not reached the ground)
    assert "no contact opens or closes" in early.notes[0]
