"""Forward sensitivities of dynamic runs (generalized-alpha, fixed steps) to numbers that enter the kernels
nonlinearly: a rope swinging down onto a penalty ground and a penalty drum (their level, radius, centre,
thickness: the forcing dR/dp from the contact kernels' direction companions) and a beam3d pendulum (its Poisson
ratio, section b and h: the stiffness's and, for b x h, the mass's derivative).

Reference: Richardson-extrapolated central differences of runs (the runs solve each step by Newton to 1e-13 of the
length: differences of runs differ from the discrete solution's by ~1e-13 / h at h = 1e-3 |p|), against the 1e-5
the dynamic derivatives must meet. The contact points do not cross the surface within +-h in these runs (the
derivative jumps where one does: the run's notes name those steps)."""
from __future__ import annotations

import numpy as np
import pytest

from ancf_sym.dynamics import DynamicOptions
from ancf_sym.dynamics.newton import NewtonOptions
from ancf_sym.sensitivity import get_parameter, with_parameter
from ancf_sym.sensitivity.adjoint import EnergyOutput, SensorOutput, dynamic_gradient
from ancf_sym.sensitivity.dynamics import dynamic_sensitivity

TIGHT = NewtonOptions(xtol=1e-13, tol=1e-12, lte_fraction=0.0, single=False)
OPTS = DynamicOptions(dt=2e-3, t_end=0.1, integrator="generalized_alpha", newton=TIGHT)
# a rope lying on a penalty ground and an arc lying on a penalty drum, each pressed in by 1 mm at the start (close to
# the weight's static penetration: every contact point stays in contact while they settle and, pinned at one end,
# swing)
ROPE = {"scene": {"name": "r", "dim": 2, "gravity": [0.0, -9.81]},
        "materials": {"m": {"E": 5e6, "density": 1200.0}}, "sections": {"s": {"area": 1e-4, "I": 1e-9}},
        "members": [{"name": "rope", "points": [[0, 0], [1.0, 0]], "elements": 6, "material": "m", "section": "s",
                     "bending": True}],
        "supports": [{"type": "pin", "member": "rope", "at": "start"}],
        "contacts": [{"type": "ground", "member": "rope", "stiffness": 1e3, "level": 5e-4, "thickness": 5e-4}]}
ARC = {"scene": {"name": "a", "dim": 2, "gravity": [0.0, -9.81]},
       "materials": {"m": {"E": 5e6, "density": 1200.0}}, "sections": {"s": {"area": 1e-4, "I": 1e-9}},
       "members": [{"name": "rope", "arc": {"centre": [0.1, -0.5], "radius": 0.503, "angle0": 2.07, "sweep": -1.0},
                    "elements": 6, "material": "m", "section": "s", "bending": True}],
       "supports": [{"type": "pin", "member": "rope", "at": "start"}],
       "contacts": [{"type": "circle", "member": "rope", "centre": [0.1, -0.5], "radius": 0.5, "stiffness": 1e3,
                     "thickness": 4e-3}]}
BEAM = {"scene": {"name": "b", "dim": 3, "gravity": [0.0, 0.0, -9.81]},
        "materials": {"m": {"E": 5e6, "density": 1200.0, "poisson": 0.3}},
        "sections": {"s": {"shape": "rectangle", "b": 0.02, "h": 0.03}},
        "members": [{"name": "beam", "points": [[0, 0, 0], [1, 0, 0]], "elements": 3, "material": "m",
                     "section": "s", "element": "beam3d", "beam_method": "elastic_line"}],
        "supports": [{"type": "clamp", "member": "beam", "at": "start"}],
        "loads": [{"type": "force", "member": "beam", "at": "end", "value": [-2.0, 0.5, 0.0]}]}
ROPE_PATHS = ["contacts[0].level", "contacts[0].thickness"]
ARC_PATHS = ["contacts[0].radius", "contacts[0].centre[0]", "contacts[0].centre[1]"]
BEAM_PATHS = ["materials.m.poisson", "sections.s.b", "sections.s.h"]


def richardson(doc, path):
    v = get_parameter(doc, path)
    h = 1e-3 * abs(v)

    def D(s):
        return (dynamic_sensitivity(with_parameter(doc, path, v + s), [], OPTS).x -
                dynamic_sensitivity(with_parameter(doc, path, v - s), [], OPTS).x) / (2 * s)
    return (4 * D(h / 2) - D(h)) / 3


@pytest.fixture(scope="module")
def runs():
    return {"rope": dynamic_sensitivity(ROPE, ROPE_PATHS, OPTS), "arc": dynamic_sensitivity(ARC, ARC_PATHS, OPTS),
            "beam": dynamic_sensitivity(BEAM, BEAM_PATHS, OPTS)}


@pytest.mark.parametrize("which", ["rope", "arc"])
def test_no_contact_opens_or_closes(runs, which):
    """(else the derivative jumps where one does, and differences across the event are no reference)"""
    assert any("no contact opens or closes" in n for n in runs[which].notes), runs[which].notes


@pytest.mark.parametrize("which, doc, path", [("rope", ROPE, p) for p in ROPE_PATHS] +
                         [("arc", ARC, p) for p in ARC_PATHS] + [("beam", BEAM, p) for p in BEAM_PATHS])
def test_forward_sensitivity(runs, which, doc, path):
    fd = richardson(doc, path)
    got = runs[which].dx[path]
    assert np.linalg.norm(fd) > 0
    assert np.linalg.norm(got - fd) <= 1e-5 * np.linalg.norm(fd), (path, np.linalg.norm(got - fd) / np.linalg.norm(fd))


@pytest.mark.parametrize("doc, paths, sensor", [(ARC, ARC_PATHS, "rope"), (BEAM, BEAM_PATHS, "beam")])
def test_adjoint_equals_forward(doc, paths, sensor):
    """The discrete adjoint's residual sum over the direction companions' gradients: the transpose of the forward
    recursion, equal to its round-off (~100 sparse solves, condition ~1e4: far inside 1e-8); and the potential
    energy at the end (its explicit dependence on p through the companion's energy derivative) against
    differences of runs."""
    sensors = [{"name": "tip", "kind": "position", "member": sensor, "at": "end"}]
    o = DynamicOptions(dt=OPTS.dt, t_end=OPTS.t_end, integrator="generalized_alpha", newton=TIGHT, sensors=sensors)
    fw = dynamic_sensitivity(doc, paths, o)
    out = SensorOutput("tip", 1, "sum")
    g = dynamic_gradient(doc, paths, o, out)
    for p in paths:
        ref = float(np.sum(fw.sensor(p, "tip")[:, 1]))
        assert abs(g.gradient[p] - ref) <= 1e-8 * abs(ref), p
    pot = EnergyOutput("potential")
    g = dynamic_gradient(doc, paths[:1], o, pot)
    v = get_parameter(doc, paths[0])
    h = 1e-3 * abs(v)
    D = lambda s: (dynamic_gradient(with_parameter(doc, paths[0], v + s), [], o, pot).value -
                   dynamic_gradient(with_parameter(doc, paths[0], v - s), [], o, pot).value) / (2 * s)
    fd = (4 * D(h / 2) - D(h)) / 3
    assert abs(g.gradient[paths[0]] - fd) <= 1e-5 * abs(fd)
