"""An exact contact's geometry (a fixed drum's radius and centre, a ground's level, a contact's thickness) in the
statics' sensitivities: it sits in the contact's unilateral rows g(x, p) >= 0, not in the potential.

At the equilibrium the active rows hold g_i(x, p) = 0 and the stationarity grad Pi - sum_i f_i grad g_i = 0, so
their derivative puts d g_i/dp into the rows' right-hand side (G dy = -dg/dp) and -sum_i f_i d(grad g_i)/dp into the
residual's (ancf_sym.sensitivity.static). The gaps g = n.r - level - t (ground) and |r - c|_perp - R - t (drum) are
linear in level, R and t (dg/dp = -1, the gradient unchanged); a fixed drum's centre is a constant input of the gap
kernel, whose exact gradient and Hessian give dg/dc_j and d(grad g)/dc_j."""
from __future__ import annotations

import numpy as np

from ancf_sym import kernels
from ancf_sym.contact import exact as contact_exact
from ancf_sym.contact.laws import DrumContact
from ancf_sym.sensitivity.paths import parse_path


def geometry_path(asm, doc: dict, path: str) -> tuple[int, str, int] | None:
    """(contact index, key, component) when `path` names an exact contact's geometry that this module
    differentiates, else None (ValueError naming the path for the geometry it does not: a ground's normal, a drum
    carried by a body)."""
    keys = parse_path(path).keys
    if keys[0] != "contacts" or len(keys) < 3 or not isinstance(keys[1], int):
        return None
    contacts = getattr(asm.scene, "contacts", ())
    if keys[1] >= len(contacts) or contacts[keys[1]].method != "exact":
        return None
    c = contacts[keys[1]]
    drum = isinstance(c, DrumContact)
    centre = len(keys) == 4 and keys[2] == "centre"
    ok = keys[2:] == ("thickness",) or (drum and (keys[2:] == ("radius",) or centre)) or \
        (not drum and keys[2:] == ("level",))
    if not ok:
        return None
    if drum and c.body is not None:
        raise ValueError(f"parameter path {path!r}: a drum carried by a body: its geometry enters the body's gap "
                         "kernel (not differentiated here)")
    return keys[1], keys[2], (keys[3] if len(keys) == 4 else 0)


def row_derivatives(asm, x: np.ndarray, where: tuple[int, str, int]) -> tuple[np.ndarray, list]:
    """(dg/dp of every exact-contact row (m,), [(row, d grad_x g/dp (n,))] for the rows whose gradient changes)."""
    i, key, comp = where
    target = asm.scene.contacts[i]
    dg, dgrad, start = [], [], 0
    for r in contact_exact.rows(asm):
        d = np.zeros(r.m)
        if r.contact is target:
            if key != "centre":
                d[:] = -1.0  # (linear in level, R, t)
            else:  # (the centre's column among the kernel's inputs: the constant const[comp])
                N, nin = r.idx.shape
                f = kernels.load(r.element, r.effect).map(N)
                Z = np.r_[np.asarray(x, float), r.const][r.idx].T
                _, G, H = f(Z, r.P.T)
                G = ca_vec(G).reshape(N, nin)  # (the kernel's gradient: nin per point, point by point)
                H = ca_vec(H).reshape(N, nin, nin)  # (symmetric: the block order does not matter)
                a = int(np.flatnonzero(r.idx[0] == asm.n + comp)[0])
                xcols = r.idx[0] < asm.n
                d[:] = G[:, a]
                for k in range(N):
                    v = np.zeros(asm.n)
                    np.add.at(v, r.idx[k][xcols], H[k, xcols, a])
                    dgrad.append((start + k, v))
        dg.append(d)
        start += r.m
    return np.concatenate(dg), dgrad


def ca_vec(M) -> np.ndarray:
    """Column-major vec of a kernel output (each point's block contiguous, as ancf_sym.contact.exact scatters it)."""
    return np.asarray(M.full() if hasattr(M, "full") else M).ravel(order="F")
