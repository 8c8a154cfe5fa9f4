"""The water in the dynamics' step system: the velocity-dependent and water-line forces beside the damping forces
(with their exact tangents), and the added mass in the mass matrix.

- forces (`force_mx`): f_d(x, v) = E' (grad U_waterline(X) - Q_drag(X, V)) on the unknowns, with df_d/dx and
  df_d/dv by AD of the one vectorized graph (ancf_sym.model.water_forces); the step graphs add them to the damping force
  (ancf_sym.dynamics.damping.dissipation_functions), so the damping work the run books includes the drag's work and
  the water line's (conservative) work;
- waves (ancf_sym.model.waves): the drag on the velocity relative to current and waves, and the fluid inertia force
  of the waves' acceleration (Froude-Krylov and added mass) join f_d, which then takes the time t as a third input
  (`timed`; the step graph reads it from the last of its time inputs w, ancf_sym.system.step_system);
- added mass: rho_w A (Ca (I - t t') + CaAx t t') per length, exact: the step system's constant mass matrix holds
  it with the tangents t0 of the run's start state (`added_mass`), and the step residual adds the rest,
  rho_w A (CaAx - Ca) (t t' - t0 t0') times the acceleration at the quadrature points (`inertia_mx`), with its
  exact tangent (t depends on q). Ca = CaAx needs no such term (the added mass is isotropic).
"""
from __future__ import annotations

import casadi as ca
import numpy as np
import scipy.sparse as sp

from ancf_sym.model.water_forces import (added_mass_matrix, drag_force, fluid_inertia_force, gravity_magnitude,
                                         point_positions, water_line_energy)
from ancf_sym.model.water_points import wet_points
from ancf_sym.model.waves import kinematics_mx
from ancf_sym.system.interface import StepSystemView


def water_of(asm):
    return getattr(asm.scene, "water", None)


def nonlinear_inertia(asm) -> bool:
    """Does the added mass turn with the line (Ca != CaAx somewhere)?"""
    if water_of(asm) is None:
        return False
    wp = _points(asm)
    return bool(np.any((wp.ca != wp.ca_axial) & (wp.wL > 0)))


def in_graph(asm) -> bool:
    """Water terms in the step graph (forces or the turning added mass): an unsymmetric step matrix."""
    return has_forces(asm) or nonlinear_inertia(asm)


def timed(asm) -> bool:
    """Do the water forces depend on time (waves)? Then f_d takes t as a third input and the step graph a time
    input (the last entry of its time inputs w)."""
    w = water_of(asm)
    return w is not None and w.waves is not None


def check_integrator(scene, integrator: str) -> None:
    """Refused before any work: waves and the collocation integrators (their stages have no time input), and the
    collocation integrators (a constant mass matrix) where the added mass turns."""
    w = getattr(scene, "water", None)
    if w is None or integrator not in ("radau", "gauss"):
        return
    if w.waves is not None:
        from ancf_sym.util.checks import fail

        raise fail("water.waves", f"run with the alpha schemes (newmark, hht, generalized_alpha), not "
                   f"integrator={integrator!r} (its stages have no time input for the waves)", vars(w.waves))
    for name, c in w.lines.items():
        if c.ca != c.ca_axial:
            from ancf_sym.util.checks import fail

            raise fail(f"water.lines.{name}.ca", f"differs from ca_axial: the added mass turns with the line, which "
                       f"the alpha schemes (newmark, hht, generalized_alpha) take exactly and integrator="
                       f"{integrator!r} does not", c.ca)


def inertia_mx(S: StepSystemView, xf: ca.MX, acc: ca.MX) -> ca.MX | None:
    """The added mass's part that turns with the line, on the unknowns: E' B' (w L rho_w A (CaAx - Ca)
    (t (t . alpha) - t0 (t0 . alpha))) with alpha = B E acc the accelerations at the points, t from xf, t0 from the
    state the constant mass matrix froze (added_mass); None where Ca = CaAx everywhere."""
    from ancf_sym.util.sparsity import dm

    asm = S.asm
    if not nonlinear_inertia(asm):
        return None
    w, wp = water_of(asm), _points(asm)
    dim, P = wp.dim, wp.P
    X = S.x_full_mx(xf)
    Acc = ca.mtimes(dm(S.E), acc)
    rx = ca.mtimes(dm(wp.Bx), X)
    rx = [rx[k * P:(k + 1) * P] for k in range(dim)]
    al = ca.mtimes(dm(wp.B), Acc)
    al = [al[k * P:(k + 1) * P] for k in range(dim)]
    n = ca.sqrt(sum(c * c for c in rx))
    t = [c / n for c in rx]
    x0 = getattr(asm, "added_mass_state", None)
    r0 = (wp.Bx @ (asm.x0 if x0 is None else np.asarray(x0, float))).reshape(dim, P)
    t0 = r0 / np.linalg.norm(r0, axis=0)
    a = w.density * np.where(wp.area > 0, wp.area, np.pi * wp.d ** 2 / 4) * wp.wL * (wp.ca_axial - wp.ca)
    ta = sum(a_ * b for a_, b in zip(t, al))
    t0a = sum(ca.DM(t0[k]) * al[k] for k in range(dim))
    f = ca.vertcat(*[ca.DM(a) * (t[k] * ta - ca.DM(t0[k]) * t0a) for k in range(dim)])
    return ca.mtimes(dm(S.E.T.tocsr()), ca.mtimes(dm(wp.B.T.tocsr()), f))


def has_forces(asm) -> bool:
    """Does the step graph carry water forces (a buoyant member's water line, drag, or waves)?"""
    w = water_of(asm)
    if w is None:
        return False
    wp = _points(asm)
    return bool(np.any(wp.area)) or wp.drag or w.waves is not None


def _points(asm):
    wp = asm.__dict__.get("_wet_points")
    if wp is None:
        wp = asm.__dict__["_wet_points"] = wet_points(asm, water_of(asm))
    return wp


def force_mx(S: StepSystemView, xf: ca.MX, vf: ca.MX, X: ca.MX, V: ca.MX, t: ca.MX | None = None) -> tuple | None:
    """(f_d, df_d/dx, df_d/dv) on the unknowns of step system S (X, V: the full coordinates and velocities as MX of
    the unknowns xf, vf; t: the time, where the water has waves), or None without water forces. The water line's
    gradient is taken with respect to xf (X is E xf + c: the chain rule gives E' grad_X U). Under waves the water's
    velocity and acceleration at the points (Airy, ancf_sym.model.waves) are expressions of X and t: their
    dependence on the position enters the tangents exactly."""
    from ancf_sym.util.sparsity import dm

    asm = S.asm
    if not has_forces(asm):
        return None
    w, wp = water_of(asm), _points(asm)
    g = gravity_magnitude(asm.scene)
    Ub = water_line_energy(wp, w, g, X)
    f = ca.gradient(Ub, xf) if Ub is not None else ca.MX.zeros(S.nf)
    flow = acc = None
    if w.waves is not None:
        _, flow, acc = kinematics_mx(w, g, point_positions(wp, X), t)
    Q = None
    if wp.drag:
        Q = drag_force(wp, w, X, V, flow=flow)
    if acc is not None and (np.any(wp.area) or wp.added_mass):
        Fi = fluid_inertia_force(wp, w, X, acc)
        Q = Fi if Q is None else Q + Fi
    if Q is not None:
        f = f - ca.mtimes(dm(S.E.T.tocsr()), Q)
    return f, ca.jacobian(f, xf), ca.jacobian(f, vf)


def added_mass(asm) -> sp.csc_matrix | None:
    """The added mass on the full coordinates at the run's start state (asm.added_mass_state, else the reference)."""
    w = water_of(asm)
    if w is None:
        return None
    wp = _points(asm)
    if not wp.added_mass:
        return None
    x = getattr(asm, "added_mass_state", None)
    return added_mass_matrix(wp, w, asm.x0 if x is None else np.asarray(x, float))


def key(asm) -> tuple | None:
    """What the step graphs bake in of the water (coefficients, current, waves and gravity, the added mass's
    state)."""
    w = water_of(asm)
    if w is None:
        return None
    c = w.current
    x = getattr(asm, "added_mass_state", None)
    return (w.density, w.depth, w.surface, w.gauss, None if c is None else (c.z.tobytes(), c.u.tobytes()),
            None if w.waves is None else tuple(vars(w.waves).values()), tuple(np.asarray(asm.scene.gravity, float)),
            tuple(sorted((k, tuple(vars(v).values())) for k, v in w.lines.items())),
            None if x is None else np.asarray(x, float).tobytes())
