"""Stiffness-proportional Rayleigh damping (C_n = alpha M + beta K_el(q_n), the elastic tangent at each step's start)
in the dynamic sensitivities: the change of beta K_el(q_n) v_{n+1} with q_n comes from the kernels' compiled
Hessian-vector companions (exact third derivatives contracted with v), dampings[i].beta is a parameter.

Forward and adjoint solve the same differentiated steps, one the transpose of the other: they agree to the
round-off of ~50 sparse solves, far inside the 1e-8 asserted. Against Richardson-extrapolated central differences of
runs converged to xtol = 1e-13 of the length: the 1e-5 relative bound of the requirement. Leaving out the third-
derivative term d(K_el(q_n) v)/dq_n errs by 4e-4..1.4e-2 on these outputs (measured while building it), so the
bound separates the two."""
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

TIGHT = NewtonOptions(xtol=1e-13, tol=1e-12, lte_fraction=0.0, single=False)
DOC = {"scene": {"name": "p", "dim": 2, "gravity": [0.0, -9.81]},
       "materials": {"m": {"E": 5e6, "density": 1200.0}}, "sections": {"s": {"area": 1e-4, "I": 1e-9}},
       "members": [{"name": "rope", "points": [[0, 0], [1.0, 0]], "elements": 6, "material": "m", "section": "s",
                    "bending": True}],
       "supports": [{"type": "pin", "member": "rope", "at": "start"}],
       "loads": [{"type": "force", "member": "rope", "at": "end", "value": [0.0, -0.5]}],
       "masses": [{"member": "rope", "at": "end", "mass": 0.05}],
       "dampings": [{"type": "rayleigh", "alpha": 2.0, "beta": 2e-3}]}
# the same rope carried sideways at its start by a position drive (a KKT step with stiffness damping)
DRIVEN = dict(copy.deepcopy(DOC), supports=[], analysis={"type": "dynamics", "dt": 2e-3, "t_end": 0.1},
              drives=[{"type": "position", "member": "rope", "at": "start",
                       "position": [[[0.0, [0.0, 0.0, 20.0]]], 0.0]}])
SENSORS = [{"name": "tip", "kind": "position", "member": "rope", "at": "end"}]
PATHS = ["materials.m.E", "dampings[0].beta", "materials.m.density", "sections.s.I", "dampings[0].alpha"]


def opts(integrator="generalized_alpha"):
    return DynamicOptions(dt=2e-3, t_end=0.1, integrator=integrator, newton=TIGHT, sensors=SENSORS)


def trapezoid(t):
    w = np.zeros(len(t))
    w[:-1] += np.diff(t) / 2
    w[1:] += np.diff(t) / 2
    return w


def richardson(f, doc, path):
    v = get_parameter(doc, path)
    s = 1e-3 * abs(v)

    def D(h):
        return (f(with_parameter(doc, path, v + h)) - f(with_parameter(doc, path, v - h))) / (2 * h)
    return (4 * D(s / 2) - D(s)) / 3


@pytest.mark.parametrize("doc,integrator", [(DOC, "generalized_alpha"), (DOC, "newmark"),
                                            (DRIVEN, "generalized_alpha")], ids=["pinned_ga", "pinned_nm", "driven"])
def test_beta_adjoint_equals_forward(doc, integrator):
    o = opts(integrator)
    fw = dynamic_sensitivity(doc, PATHS, o)
    g = dynamic_gradient(doc, PATHS, o, SensorOutput("tip", 1, "integral"))
    for p in PATHS:
        ref = trapezoid(fw.t) @ fw.sensor(p, "tip")[:, 1]
        assert abs(g.gradient[p] - ref) <= 1e-8 * abs(ref), p


@pytest.mark.parametrize("doc,out", [(DOC, SensorOutput("tip", 1, "integral")), (DOC, EnergyOutput("kinetic")),
                                     (DRIVEN, SensorOutput("tip", 1, "integral"))],
                         ids=["pinned_tip", "pinned_kinetic", "driven_tip"])
def test_beta_adjoint_matches_central_differences(doc, out):
    o = opts()
    paths = ["materials.m.E", "dampings[0].beta", "sections.s.I"]
    g = dynamic_gradient(doc, paths, o, out)
    for p in paths:
        fd = richardson(lambda d: dynamic_gradient(d, [], o, out).value, doc, p)
        assert abs(g.gradient[p] - fd) <= 1e-5 * abs(fd), (p, g.gradient[p], fd)


def test_beta_zero_refused_by_name():
    d = copy.deepcopy(DOC)
    d["dampings"][0]["beta"] = 0.0
    with pytest.raises(SceneError, match=r"dampings\[0\].beta"):
        dynamic_gradient(d, ["dampings[0].beta"], opts(), SensorOutput("tip", 1))


def test_beta_from_the_static_start_under_a_load_pulse():
    """Start at the static equilibrium (its sensitivity is the first state's: the damping's q_n-term is fed from
    the start), a sideways pulse (analysis.loads) sets the rope moving; forward = adjoint, adjoint = differences."""
    doc = copy.deepcopy(DOC)
    pulse = [{"member": "rope", "at": "end", "force": [0.4, 0.0], "history": [[0.0, 0.0], [0.05, 1.0], [0.1, 0.0]]}]
    o = DynamicOptions(dt=2e-3, t_end=0.1, newton=TIGHT, sensors=SENSORS, start="static", loads=pulse)
    out = SensorOutput("tip", 0, "integral")
    paths = ["materials.m.E", "dampings[0].beta", "sections.s.I"]
    fw = dynamic_sensitivity(doc, paths, o)
    g = dynamic_gradient(doc, paths, o, out)
    for p in paths:
        ref = trapezoid(fw.t) @ fw.sensor(p, "tip")[:, 0]
        assert abs(g.gradient[p] - ref) <= 1e-8 * abs(ref), p
        fd = richardson(lambda d: dynamic_gradient(d, [], o, out).value, doc, p)
        assert abs(g.gradient[p] - fd) <= 1e-5 * abs(fd), (p, g.gradient[p], fd)
