"""The water in the dynamics' step system: the velocity-dependent and water-line forces beside the damping forces
(with their exact tangents), and the added mass in the mass matrix.

- forces (`force_mx`): f_d(x, v) = E' (grad U_waterline(X) - Q_drag(X, V)) on the unknowns, with df_d/dx and
  df_d/dv by AD of the one vectorized graph (ancf_sym.water.forces); the step graphs add them to the damping force
  (ancf_sym.dynamics.damping.dissipation_functions), so the damping work the run books includes the drag's work and
  the water line's (conservative) work;
- added mass (`added_mass`): rho_w A (Ca (I - t t') + CaAx t t') per length with the tangents t frozen at the run's
  start state (the step system's mass matrix is constant over a run); Ca = CaAx is exact at any state.
"""
from __future__ import annotations

import casadi as ca
import numpy as np
import scipy.sparse as sp

from .forces import added_mass_matrix, drag_force, gravity_magnitude, water_line_energy
from .points import wet_points


def water_of(asm):
    return getattr(asm.scene, "water", None)


def has_forces(asm) -> bool:
    """Does the step graph carry water forces (a buoyant member's water line, or drag)?"""
    w = water_of(asm)
    if w is None:
        return False
    wp = _points(asm)
    return bool(np.any(wp.area)) or wp.drag


def _points(asm):
    wp = asm.__dict__.get("_wet_points")
    if wp is None:
        wp = asm.__dict__["_wet_points"] = wet_points(asm, water_of(asm))
    return wp


def force_mx(S, xf: ca.MX, vf: ca.MX, X: ca.MX, V: ca.MX) -> tuple | None:
    """(f_d, df_d/dx, df_d/dv) on the unknowns of step system S (X, V: the full coordinates and velocities as MX of
    the unknowns xf, vf), or None without water forces. The water line's gradient is taken with respect to xf (X
    is E xf + c: the chain rule gives E' grad_X U)."""
    from ..sparsity import dm

    asm = S.asm
    if not has_forces(asm):
        return None
    w, wp = water_of(asm), _points(asm)
    Ub = water_line_energy(wp, w, gravity_magnitude(asm.scene), X)
    f = ca.gradient(Ub, xf) if Ub is not None else ca.MX.zeros(S.nf)
    if wp.drag:
        f = f - ca.mtimes(dm(S.E.T.tocsr()), drag_force(wp, w, X, V))
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
    """What the step graphs bake in of the water (coefficients, current, the added mass's state)."""
    w = water_of(asm)
    if w is None:
        return None
    c = w.current
    x = getattr(asm, "added_mass_state", None)
    return (w.density, w.depth, w.surface, w.gauss, None if c is None else (c.z.tobytes(), c.u.tobytes()),
            tuple(sorted((k, tuple(vars(v).values())) for k, v in w.lines.items())),
            None if x is None else np.asarray(x, float).tobytes())
