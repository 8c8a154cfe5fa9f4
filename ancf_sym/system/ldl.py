"""In-graph sparse LDL^T factorisation of the symmetric positive definite step matrix, whose factor is a value: a
compiled step can keep it across iterations and steps (modified Newton in the alpha schemes' step graph).

fact_f(KKT nonzeros) -> (D, U, U^T nonzeros) with P A P^T = U^T diag(D) U, U unit upper triangular, P a
fill-reducing AMD ordering; `solve_mx` applies it with two sparse triangular solves and a scaling.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from ancf_sym.util.sparsity import sx_nonzeros

# largest LDL^T factorisation (operations of its SX graph) built for in-graph modified Newton
MAX_FACTOR_OPS = 2_000_000


@dataclass
class LDLFactor:
    fact_f: ca.Function  # KKT nonzeros -> D, U, U^T nonzeros
    perm: np.ndarray  # the fill-reducing ordering
    sparsity: tuple  # (U, U^T) patterns
    size: tuple  # (len D, nnz U, nnz U^T)

    def solve_mx(self, D: ca.MX, U: ca.MX, UT: ca.MX, b: ca.MX) -> ca.MX:
        """A^-1 b from the values of fact_f (MX: two sparse triangular solves and a scaling)."""
        spU, spUT = self.sparsity
        p = self.perm
        permuted = bool(np.any(p != np.arange(len(p))))
        y = b[p.tolist()] if permuted else b
        y = ca.solve(ca.MX(spUT, UT), y) / D
        y = ca.solve(ca.MX(spU, U), y)
        return y[np.argsort(p).tolist()] if permuted else y


def build_ldl(spK: ca.Sparsity, max_ops: int = MAX_FACTOR_OPS) -> LDLFactor | None:
    """The factorisation of matrices with pattern spK (n x n, symmetric positive definite values), or None when its
    graph would exceed max_ops operations."""
    n = spK.size1()
    spLT, _ = spK.ldl(True)
    counts = np.diff(np.array(spLT.colind()))  # entries above the diagonal per column of U
    if float(np.sum((counts + 1.0) ** 2)) > max_ops:
        return None
    a = ca.SX.sym("a", spK.nnz())
    D, LT, p = ca.ldl(ca.SX(spK, a), True)
    U = LT + ca.SX.eye(n)
    UT = U.T
    fact_f = ca.Function("ldl_factor", [a], [D, sx_nonzeros(U), sx_nonzeros(UT)], ["kkt"], ["D", "U", "UT"])
    return LDLFactor(fact_f, np.array(p, dtype=np.int64), (U.sparsity(), UT.sparsity()), (n, U.nnz(), UT.nnz()))
