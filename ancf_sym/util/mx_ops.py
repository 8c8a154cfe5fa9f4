"""MX arithmetic through `MX.binary` / `MX.unary`: CasADi's Python operators and overloaded functions (`+`, `*`,
`ca.fabs`) resolve their overloads at ~30 us a call, these at ~3 us; the dynamics' step graphs (and the sums of
their assembly) are built at every first run of a structure. The same nodes, the same simplifications (CasADi's
operators call MX::binary themselves). Reshapes of dense MX likewise through the MX(Sparsity, MX) constructor."""
from __future__ import annotations

import casadi as ca


def add(x: ca.MX, y: ca.MX) -> ca.MX:
    return ca.MX.binary(ca.OP_ADD, x, y)


def sub(x: ca.MX, y: ca.MX) -> ca.MX:
    return ca.MX.binary(ca.OP_SUB, x, y)


def mul(x: ca.MX, y: ca.MX) -> ca.MX:
    return ca.MX.binary(ca.OP_MUL, x, y)


def div(x: ca.MX, y: ca.MX) -> ca.MX:
    return ca.MX.binary(ca.OP_DIV, x, y)


def neg(x: ca.MX) -> ca.MX:
    return ca.MX.unary(ca.OP_NEG, x)


def fabs(x: ca.MX) -> ca.MX:
    return ca.MX.unary(ca.OP_FABS, x)


def reshape(x: ca.MX, n_rows: int, n_cols: int) -> ca.MX:
    """ca.reshape(x, n_rows, n_cols), column-major: for a dense x the same node from CasADi's MX(Sparsity, MX)
    constructor (a reshape where the patterns fit) at ~1/3 of the overloaded function's cost; ca.reshape else."""
    if x.is_dense() and x.numel() == n_rows * n_cols:
        return ca.MX(ca.Sparsity.dense(n_rows, n_cols), x)
    return ca.reshape(x, n_rows, n_cols)


def vec(x: ca.MX) -> ca.MX:
    """ca.vec(x) (the column-major column of x) through `reshape`."""
    return reshape(x, x.numel(), 1)
