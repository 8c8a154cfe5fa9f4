"""Dynamic sensitivities from a static start held by constraint rows with multipliers (an L frame: a rigid joint's
bilinear rows, a rigid body pinned at its tip): the start's state derivative is the equilibrium's (the implicit
function theorem on [K_0 + H(lam_s), J'; J, 0]), the initial acceleration and multipliers follow from
[M J'; J 0] differentiated (the rows' curvature H(lam_0) and d(J(q) a_0)/dq included).

Forward and adjoint transpose the same solves: they agree to the round-off of ~50 sparse QR solves (condition ~1e5
with the multiplier rows), far inside the 1e-8 asserted. Against Richardson-extrapolated central differences of
runs converged to xtol = 1e-13 of the length (the static start to the statics' own tolerance): the 1e-5 relative
bound of the requirement. Leaving out H(lam_0) dq_0 errs by 2e-5..3e-3 on these outputs, leaving out
d(J a_0)/dq dq_0 by 4e-7..1e-5 on lam_0 (measured while building it): the bounds separate them."""
from __future__ import annotations

import copy

import numpy as np
import pytest

from ancf_sym.dynamics import DynamicOptions
from ancf_sym.dynamics.newton import NewtonOptions
from ancf_sym.sensitivity import get_parameter, with_parameter
from ancf_sym.sensitivity.adjoint import EnergyOutput, SensorOutput, dynamic_gradient
from ancf_sym.sensitivity.dynamics import dynamic_sensitivity

TIGHT = NewtonOptions(xtol=1e-13, tol=1e-12, lte_fraction=0.0, single=False)
# an L frame (rigid joint) pinned at its start, a rigid body pinned at its tip (the body's rows)
FRAME = {"scene": {"name": "p", "dim": 2, "gravity": [0.0, -9.81]},
         "materials": {"m": {"E": 2e5, "density": 1200.0}}, "sections": {"s": {"area": 1e-4, "I": 2e-9}},
         "members": [{"name": "a", "points": [[0, 0], [0.5, 0]], "elements": 3, "material": "m", "section": "s",
                      "bending": True},
                     {"name": "b", "points": [[0.5, 0], [0.5, -0.5]], "elements": 3, "material": "m",
                      "section": "s", "bending": True}],
         "supports": [{"type": "pin", "member": "a", "at": "start"}],
         "joints": [{"type": "rigid", "a": ["a", "end"], "b": ["b", "start"]}],
         "bodies": [{"name": "tip", "mass": 0.05, "inertia": 1e-4, "position": [0.6, -0.5], "pin": [["b", "end"]]}]}
SENSORS = [{"name": "tip", "kind": "position", "member": "b", "at": "end"}]
PATHS = ["materials.m.E", "materials.m.density", "sections.s.I", "scene.gravity[1]"]


def pulse(at_start: float, force: float = 0.05) -> list:
    """A sideways push on the frame's tip (analysis.loads); at_start > 0: already on at t = 0 (a_0 != 0)."""
    return [{"member": "b", "at": "end", "force": [force, 0.0],
             "history": [[0.0, at_start], [0.05, 1.0], [0.1, 0.0]]}]


def opts(loads, integrator="generalized_alpha", t_end=0.1):
    return DynamicOptions(dt=2e-3, t_end=t_end, integrator=integrator, newton=TIGHT, sensors=SENSORS,
                          start="static", loads=loads)


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


@pytest.mark.parametrize("at_start,integrator", [(0.0, "generalized_alpha"), (1.0, "newmark")])
def test_static_start_with_rows_adjoint_equals_forward(at_start, integrator):
    o = opts(pulse(at_start), integrator)
    fw = dynamic_sensitivity(FRAME, PATHS, o)
    assert fw.lam.shape[1] >= 2 and np.max(np.abs(fw.dx["sections.s.I"][0])) > 0.0  # (rows; q_0 moves with p)
    g = dynamic_gradient(FRAME, PATHS, o, SensorOutput("tip", 0, "integral"))
    for p in PATHS:
        ref = trapezoid(fw.t) @ fw.sensor(p, "tip")[:, 0]
        scale = trapezoid(fw.t) @ np.max(np.abs(fw.dx[p]), axis=1)  # (round-off relative to the state's)
        assert abs(g.gradient[p] - ref) <= 1e-8 * max(abs(ref), scale), (p, g.gradient[p], ref)


@pytest.mark.parametrize("at_start,out", [(0.0, SensorOutput("tip", 0, "integral")), (1.0, EnergyOutput("kinetic"))],
                         ids=["tip", "kinetic_loaded_start"])
def test_static_start_with_rows_matches_central_differences(at_start, out):
    o = opts(pulse(at_start, 2.0 if at_start else 0.05))
    g = dynamic_gradient(FRAME, PATHS, o, out)
    for p in PATHS:
        fd = richardson(lambda d: dynamic_gradient(d, [], o, out).value, FRAME, p)
        assert abs(g.gradient[p] - fd) <= 1e-5 * abs(fd), (p, g.gradient[p], fd)


def test_start_multipliers_match_differences():
    """d lam_0/dp with a load on at t = 0 (a_0 != 0: the term d(J(q) a_0)/dq dq_0 counts) against differences of
    the start's multipliers (a direct solve at the equilibrium: differences good to ~1e-9 here)."""
    o = opts(pulse(1.0, 2.0), t_end=0.004)
    for p in ("sections.s.I", "materials.m.density"):
        fw = dynamic_sensitivity(FRAME, [p], o)
        fd = richardson(lambda d: dynamic_sensitivity(d, [], o).lam[0], FRAME, p)
        assert np.max(np.abs(fw.dlam[p][0] - fd)) <= 1e-6 * np.max(np.abs(fd)), p


def test_static_start_without_loads_stays_at_rest():
    """From the equilibrium at rest with nothing pushing, the state stays put: its derivative is the statics' at
    every step, the acceleration's is nil (a check of the start's consistency: da_0 = 0, dlam_0 = the reactions')."""
    o = opts([])
    doc = copy.deepcopy(FRAME)
    fw = dynamic_sensitivity(doc, ["sections.s.I"], o)
    d = fw.dx["sections.s.I"]
    assert np.max(np.abs(d[-1] - d[0])) <= 1e-8 * np.max(np.abs(d[0]))
    assert np.max(np.abs(fw.dv["sections.s.I"])) <= 1e-8 * np.max(np.abs(d[0])) / o.dt
