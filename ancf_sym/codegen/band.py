"""Banded LDL^T kernels: the factorisation and solve of a symmetric positive definite matrix of half-bandwidth w
(a_ij = 0 for |i - j| > w), as straight-line SX over chunks of m columns, generated to C like the element kernels.

A step graph calls them once per chunk (n / m calls in sequence, ancf_sym.system.band): the sparse LDL^T of a
general pattern runs at one dependent multiply-add at a time (a sparse dot product per entry of the factor), where
a band's rank-one updates are independent operations the processor overlaps. No pivoting, as CasADi's "ldl".

band_ldl_fwd_w<w>_m<m>: (state, A (w+1 x m), b (m)) -> (state, L (w x m), z (m))
    Right-looking factorisation of columns j = 0..m-1 of the chunk with forward substitution: A[:, j] holds
    a_(j..j+w, j) (the column's lower band), b the right-hand side. state: the Schur complement updates that earlier
    columns made on the next w rows and columns (w (w + 1) / 2, upper triangle by rows), their updates of b (w), and
    max |a_jj| so far (1). Out: L[:, j] = l_(j+1..j+w, j), z_j = y_j / d_j with L y = b, d_j the pivot.
band_ldl_bwd_w<w>_m<m>: (state, L (w x m), z (m)) -> (state, x (m))
    Back substitution over the chunk's columns from the last: x_j = z_j - sum_k l_(j+k, j) x_(j+k). state: x of the w
    columns after the chunk (w), and max |x| so far (1).
"""
from __future__ import annotations

import casadi as ca

from ancf_sym import registry


def forward(w: int, m: int) -> ca.Function:
    nu = w * (w + 1) // 2
    st = ca.SX.sym("state", nu + w + 1)
    A = ca.SX.sym("A", w + 1, m)
    b = ca.SX.sym("b", m)
    U, k = {}, 0
    for i in range(w):
        for c in range(i, w):
            U[i, c] = st[k]
            k += 1
    ub = [st[nu + i] for i in range(w)]
    amax = st[nu + w]
    Ls, zs = [], []
    for j in range(m):
        col = [A[i, j] + U[0, i] if i < w else A[i, j] for i in range(w + 1)]
        amax = ca.fmax(amax, ca.fabs(A[0, j]))
        inv = 1 / col[0]
        lj = [col[i] * inv for i in range(1, w + 1)]
        y = b[j] + ub[0]
        # the rank-one update of the next w rows and columns: u'_(i-1, c-1) = u_(i, c) - l_i a_c (row w: no update yet)
        U = {(i - 1, c - 1): (U[i, c] if c < w else 0) - lj[i - 1] * col[c]
             for i in range(1, w + 1) for c in range(i, w + 1)}
        ub = [(ub[i] if i < w else 0) - lj[i - 1] * y for i in range(1, w + 1)]
        Ls.append(ca.vertcat(*lj))
        zs.append(y * inv)
    out = ca.vertcat(*[U[i, c] for i in range(w) for c in range(i, w)], *ub, amax)
    return ca.Function(registry.band_name("fwd", w, m), [st, A, b], [out, ca.horzcat(*Ls), ca.vertcat(*zs)],
                       ["state", "A", "b"], ["state_out", "L", "z"])


def backward(w: int, m: int) -> ca.Function:
    st = ca.SX.sym("state", w + 1)
    L = ca.SX.sym("L", w, m)
    z = ca.SX.sym("z", m)
    after = [st[i] for i in range(w)]  # x_(j+1..j+w)
    xmax = st[w]
    xs = [None] * m
    for j in reversed(range(m)):
        xj = z[j] - ca.dot(L[:, j], ca.vertcat(*after))
        xmax = ca.fmax(xmax, ca.fabs(xj))
        xs[j] = xj
        after = [xj] + after[:-1]
    return ca.Function(registry.band_name("bwd", w, m), [st, L, z], [ca.vertcat(*after, xmax), ca.vertcat(*xs)],
                       ["state", "L", "z"], ["state_out", "x"])


def functions() -> list[ca.Function]:
    """The kernels of every (w, m) in registry.BAND_LDL."""
    return [f for w, m in registry.BAND_LDL for f in (forward(w, m), backward(w, m))]
