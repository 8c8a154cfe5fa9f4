"""The linear model of a scene in water about its equilibrium (ancf_sym.statics.water), on the unknowns of the water
statics (the supports and the fairleads' drives held):

- K: the exact Jacobian of the statics' residual, grad Pi - Q_water plus the multiplier rows' curvature: the
  Hessian of the potential with the buoyancy (the gravity term's net weight) and the water line's, and, where a
  current drags, minus d Q_drag / dx at rest: the drag's load stiffness (the drag follows the line's tangent and
  position), which makes K unsymmetric;
- M: the structure's mass plus the added mass rho_w A (Ca (I - t t') + CaAx t t') with the equilibrium's tangents
  t: exact for the linear model (the added mass's dependence on the state multiplies the acceleration, which is zero
  at the equilibrium);
- D (damping_matrix): the scene's damping (Rayleigh with M including the added mass, strain rate, contact
  dissipation) plus d f / d v of the Morison drag at rest (the step system's own AD graph): the drag's damping,
  linear in the current's relative velocity (without a current the quadratic drag has no linear part).
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ancf_sym.model.reduced import Partition
from ancf_sym.model.water_forces import added_mass_matrix
from ancf_sym.model.water_points import wet_points
from ancf_sym.scene.builder import SceneError

SYMMETRIC_REL = 1e-10  # |K - K'| below this times |K|: symmetric (round-off of the AD Hessians), symmetrised


def water_matrices(result, part: Partition, damping_fn, damping_matrix: bool):
    """(M, K, D, G, E, multipliers, J_full, G_full, asm) of a statics result in water. damping_fn(asm, x, part,
    M_part): the scene's damping on the partition's unknowns (ancf_sym.modal.linearize), restricted here to the
    unknowns the water statics keep."""
    ws = getattr(result, "water", None)
    if ws is None or not getattr(result, "success", False):
        raise SceneError("linearize: a scene in water needs its successful statics result (the water statics' "
                         "equilibrium and multipliers), not a coordinate vector")
    asm, x = ws.asm, np.asarray(result.x, float)
    E = ws.E.tocsc()
    if part.E.shape != (asm.n, part.ny) or (part.E[:, ws.keep] - E).count_nonzero():
        raise SceneError("linearize: the statics result in water is not of this scene")
    _, Jd, _, Gd = ws.full(x, 1.0, ws.mu)
    J, Gf = sp.csc_matrix(Jd.sparse()), sp.csr_matrix(Gd.sparse())
    K = (E.T @ J @ E).tocsc()
    asym = abs(K - K.T).max() if K.nnz else 0.0
    if asym <= SYMMETRIC_REL * (abs(K).max() if K.nnz else 0.0):
        K = (0.5 * (K + K.T)).tocsc()
    Mf = asm.mass_matrix()
    wp = wet_points(asm, ws.water)
    if wp.added_mass:
        Mf = (Mf + added_mass_matrix(wp, ws.water, x)).tocsc()
    M = (E.T @ Mf @ E).tocsc()
    D = None
    if damping_matrix:
        Dp = damping_fn(asm, x, part, part.reduce_matrix(Mf))
        if Dp is not None:
            D = sp.csc_matrix(Dp)[ws.keep][:, ws.keep].tocsc()
    G = (Gf @ E).tocsr()
    return M, K, D, G, E, np.asarray(ws.mu, float), J, Gf, asm
