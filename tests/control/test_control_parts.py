"""The parts of a control problem stand alone (composition, not mixins): the model gives a hanging rope's static
equilibrium without any NLP, and a warm start built from the parts (options, model, bounds, transcription)
satisfies every dynamics row of the NLP it was built for."""
from __future__ import annotations

import numpy as np
from scipy.integrate import quad

from ancf_sym import Material, Scene, Section
from ancf_sym.control import ControlModel, Effort, PointMass, SupportMotion
from ancf_sym.control.bounds import Bounds
from ancf_sym.control.options import control_options
from ancf_sym.control.transcription import Transcription
from ancf_sym.control.warm_start import WarmStart

G, L, E, A, RHO, MASS = 9.81, 5.0, 100e9, 7.85e-5, 7850.0, 100.0


def rope(n: int = 4) -> Scene:
    s = Scene(dim=2, gravity=(0.0, -G))
    s.member("rope", points=[(0.0, 0.0), (0.0, -L)], elements=n, material=Material(E=E, density=RHO),
             section=Section(area=A, I=1e-11), axial="green", bending=True)
    s.pin("rope", "start")
    return s


def model() -> ControlModel:
    return ControlModel(rope(), [SupportMotion("rope", "start", name="trolley")], [PointMass("rope", "end", MASS)])


def test_model_alone_gives_the_hanging_rope_stretch():
    """Tension N(x) = g (m + rho A (L - x)); Green strain N / EA, so |r_x| = sqrt(1 + 2 N / EA): the end hangs
    by the integral of |r_x| - 1 below L. The strain (~1e-4) is linear along the rope and cubic Hermite elements
    hold it but for the square root's curvature (relative eps^2 ~ 1e-8 of |r_x|, ~1e-4 of the stretch): 1e-3."""
    m = model()
    q = m.equilibrium(np.zeros(m.nc))
    x = m.full(q, np.zeros(m.nc))
    idx, w = m.probe("rope", "end")
    end = np.array([x[row] @ w for row in idx])
    stretch = quad(lambda s: np.sqrt(1 + 2 * G * (MASS + RHO * A * (L - s)) / (E * A)) - 1, 0, L)[0]
    assert abs(end[0]) <= 1e-9 * L  # hangs straight below the pin
    assert abs((-end[1] - L) - stretch) <= 1e-3 * stretch


def test_warm_start_from_the_parts_satisfies_the_dynamics_rows():
    """The collocation simulation solves each interval's stage equations by Newton to 1e-9 of the largest constant
    force (the weights) or to a last step at round-off, so the NLP's dynamics rows hold to 1e-8 of it at the warm
    start; only the end rows are off."""
    m = model()
    opts = control_options(4.0, [Effort()], [], [], 4, 3, "radau", True, None, None, "polynomial", 1e-8, 100, 0,
                           None)
    lim = Bounds(m, opts, {}, {}, {"trolley.position": 2.0})
    s0, s1 = m.chan_vector(lim.start_values), m.chan_vector(lim.end_values)
    q0, q1 = m.equilibrium(s0), m.equilibrium(s1)
    tr = Transcription(m, opts, lim, q0, q1, m.vibration_modes(q1, s1))
    w, info = WarmStart(m, opts, lim, tr, q0).warm_start()
    assert info["converged"], info
    g = np.asarray(tr.g_function(w)).ravel()
    a, b = tr.g_rows["dynamics"]
    fscale = np.max(np.abs(m.f_lin))
    assert np.max(np.abs(g[a:b])) <= 1e-8 * fscale
    a, b = tr.g_rows["end"]
    assert np.max(np.abs(g[a:b])) > 1e-3  # the naive motion leaves the payload swinging (what IPOPT then removes)
