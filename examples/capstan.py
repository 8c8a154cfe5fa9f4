"""Capstan: a rope over a fixed drum with friction, masses at its ends released from rest, against the capstan
(Euler-Eytelwein) law.

A light rope (d = 3 mm, E = 10 GPa, rho = 300, no bending stiffness) hangs over a fixed drum of radius R = 0.1 m
(wrap angle theta = pi, legs of 0.8 m) with regularised Coulomb friction mu (eps = 5 mm/s) and a linear penalty
normal law. The project has no point masses, so each end mass is a short dense member (5 cm, 2 elements) joined to
the rope by a hinge: its whole mass m hangs at the rope's end, its length is small against the legs. The rope's
reference is straight and unstrained; the run starts from the wrapped state (arc-length parametrised, so unstrained)
at rest. Law for a massless rope: the masses stick while m_heavy / m_light <= e^(mu theta); else they slide with
    a = g (m_h - m_l e^(mu theta)) / (m_h + m_l e^(mu theta)).
Rope-mass correction (first order in the rope's mass, here 0.5 % of the masses): each leg's weight joins its end
mass in the driving terms and the whole rope's mass joins the inertia,
    a = g (m_h' - m_l' e) / (m_h' + m_l' e + m_rope),   m' = m + rho A l_leg.
The acceleration of the heavy mass (downward positive) is the slope of a straight-line fit of its velocity after
the start transient (t >= 0.25 s: the rope takes up its tension through axial waves, damped by a strain-rate
damping). A sticking rope creeps at a constant speed below eps (regularised friction), its acceleration is zero.
Records: case, mu, wrap_rad, m_heavy, m_light, ratio, acceleration, acceleration_law (0 when sticking), error,
creep_speed (mean speed after the transient), stick (bool, measured: |a| below 2 % of g), stick_law.

Run: python examples/capstan.py [--quick] [--json out.json] [--out DIR]
"""
from __future__ import annotations

import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common as C  # noqa: E402  (first: it limits BLAS threads before numpy loads)

import numpy as np  # noqa: E402

from ancf_sym import Material, Scene, Section  # noqa: E402
from ancf_sym.model.assembly import Assembly  # noqa: E402
from ancf_sym.dynamics import DynamicOptions, Sensor, simulate  # noqa: E402

G = 9.81
R, LEG, LM, THETA = 0.1, 0.8, 0.05, math.pi
ROPE = Material(E=1e10, density=300.0)
SEC = Section.circle(0.003)
MASS_SEC = Section.circle(0.02)
EPS, STICK_A = 5e-3, 0.02 * G
# the drum contact acts on the rope's surface (half thickness = its radius by default): the wrapped centre line lies
# on that surface, at gap 0; wrapped at R it would start 1.5 mm deep in the penalty (0.44 J stored, enough to throw
# the masses up at 0.35 m/s and slacken the rope for the first 0.2 s)
RC = R + math.sqrt(SEC.area / math.pi)
T_TRANSIENT = 0.25  # the rope takes up its tension and the release's axial waves decay (damped) by then


def law(mu: float, m_h: float, m_l: float, m_rope: float = 0.0, m_leg: float = 0.0) -> float:
    """Capstan law (0 while sticking), with the first-order rope-mass correction of the module docstring."""
    e = math.exp(mu * THETA)
    mh, ml = m_h + m_leg, m_l + m_leg
    return max(0.0, G * (mh - ml * e) / (mh + ml * e + m_rope))


def _path(s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points and unit tangents at arc length s of the wrapped centre line (radius RC over the drum): up the left
    leg, over the drum (angle pi to 0), down the right leg; the masses continue the legs downwards."""
    r, t = np.zeros((len(s), 2)), np.zeros((len(s), 2))
    arc = RC * THETA
    for k, sk in enumerate(s):
        if sk <= LEG + LM:
            r[k], t[k] = (-RC, -(LEG + LM) + sk), (0.0, 1.0)
        elif sk <= LEG + LM + arc:
            a = math.pi - (sk - LEG - LM) / RC
            r[k], t[k] = (RC * math.cos(a), RC * math.sin(a)), (math.sin(a), -math.cos(a))
        else:
            r[k], t[k] = (RC, -(sk - LEG - LM - arc)), (0.0, -1.0)
    return r, t


def run_case(name: str, mu: float, m_h: float, m_l: float, t_end: float, n_rope: int) -> dict:
    L = 2 * LEG + RC * THETA
    sc = Scene(dim=2, gravity=(0.0, -G), name=f"capstan_{name}")
    # straight unstrained reference along x (mass_l | rope | mass_h); the run starts from the wrapped state
    for nm, a, b, m in (("mass_l", -LM, 0.0, m_l), ("rope", 0.0, L, None), ("mass_h", L, L + LM, m_h)):
        mat = ROPE if m is None else Material(E=ROPE.E, density=m / (LM * MASS_SEC.area))
        sc.member(nm, [(a, 0.0), (b, 0.0)], n_rope if m is None else 2, mat, SEC if m is None else MASS_SEC,
                  bending=m is not None)
    sc.hinge(("mass_l", "end"), ("rope", "start"))
    sc.hinge(("rope", "end"), ("mass_h", "start"))
    sc.contact_drum("rope", (0.0, 0.0), R, stiffness=1e6, mu=mu, eps=EPS, damping=1e3)
    sc.strain_rate_damping(axial=ROPE.E * SEC.area * 5e-3, members=["rope"])
    asm = Assembly(sc)
    q0 = asm.x0.copy()
    for nm, s0 in (("mass_l", -LM), ("rope", 0.0), ("mass_h", L)):
        mm = asm.mesh.members[nm]
        n = len(mm.x0)
        s = s0 + np.linspace(0.0, LM if nm != "rope" else L, n) + LM
        r, t = _path(s)
        for k in range(n):
            q0[mm.node_dofs(k)] = np.r_[r[k], t[k]]
    opts = DynamicOptions(dt=1e-3, t_end=t_end, q0=q0, rho_inf=0.6, output_dt=2e-3, energies=False,
                          sensors=[Sensor("v", "velocity", "mass_h", "end")])
    res = simulate(asm, opts)
    t, v = np.asarray(res.t), -np.asarray(res.sensors["v"])[:, 1]
    keep = t >= T_TRANSIENT
    acc = float(np.polyfit(t[keep], v[keep], 1)[0]) if res.success else float("nan")
    m_rope = ROPE.density * SEC.area * L
    ref = law(mu, m_h, m_l, m_rope, ROPE.density * SEC.area * LEG)
    e = math.exp(mu * THETA)
    return {"case": name, "mu": mu, "wrap_rad": THETA, "m_heavy": m_h, "m_light": m_l, "ratio": m_h / m_l,
            "stick_limit": e, "acceleration": acc, "acceleration_law": ref,
            "acceleration_law_massless": law(mu, m_h, m_l), "error": acc - ref,
            "creep_speed": float(np.mean(v[keep])), "stick": bool(abs(acc) < STICK_A), "stick_law": bool(m_h / m_l <= e), "success": res.success,
            "status": res.status, "steps": res.steps, "wall_s": res.wall_s}


CASES = [("mu0.2_r1.5", 0.2, 1.5, 1.0), ("mu0.2_r2.5", 0.2, 2.5, 1.0), ("mu0.2_r4", 0.2, 4.0, 1.0),
         ("mu0.1_r1.2", 0.1, 1.2, 1.0), ("mu0.1_r2", 0.1, 2.0, 1.0), ("mu0.2_r1.7", 0.2, 1.7, 1.0),
         ("mu0_r2", 0.0, 2.0, 1.0)]


def main(argv=None):
    a = C.parser("capstan", __doc__).parse_args(argv)
    cases = CASES[:4] if a.quick else CASES
    records = [run_case(n, mu, mh, ml, 0.45 if a.quick else 0.55, 24 if a.quick else 40) for n, mu, mh, ml in cases]
    C.table(records, ["case", "mu", "ratio", "stick_limit", "acceleration", "acceleration_law", "error", "stick",
                      "stick_law", "status"])

    def plots(out):
        plt = C.pyplot()
        fig, ax = plt.subplots(figsize=(6.5, 4.2))
        for mu, style in ((0.0, "C2"), (0.1, "C1"), (0.2, "C0")):
            rs = [r for r in records if r["mu"] == mu]
            if not rs:
                continue
            x = np.linspace(1.0, 4.2, 200)
            ax.plot(x, [law(mu, xi, 1.0) for xi in x], "-", color=style, label=f"capstan law, mu = {mu}")
            ax.plot([r["ratio"] for r in rs], [r["acceleration"] for r in rs], "o", color=style,
                    label=f"ANCF, mu = {mu}")
        ax.set_xlabel("m_heavy / m_light"), ax.set_ylabel("acceleration of the heavy mass [m/s^2]")
        ax.set_title(f"rope over a fixed drum, wrap angle pi"), ax.legend(fontsize=8)
        C.save(fig, out, "capstan.png")

    return C.finish(records, a, plots)


if __name__ == "__main__":
    main()
