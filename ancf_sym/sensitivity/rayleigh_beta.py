"""Which elements a stiffness-proportional Rayleigh damping acts on, and with which beta, for its derivatives.

The run's damping is C = alpha M + beta_ref K_el(q) with K_el = sum_e w_e H_e(q) over the elastic energies'
elements (ancf_sym.system.damping.rayleigh_data: w_e = beta of the element's member / beta_ref, a member taking the
beta of the last [[dampings]] entry naming it, or naming no members). So C's elastic part is sum_e beta_m(e) H_e:
d C / d dampings[i].beta = sum of H_e over the members whose beta entry i gives, and a model parameter p changes it by
sum_e beta_m(e) dH_e/dp. The per-element betas are read from the run's own weights (not re-derived), the entry that
gives each member its beta from the scene's dampings in the reader's order.
"""
from __future__ import annotations

import numpy as np

from ancf_sym.system.forces import ELASTIC_LABELS


def member_of_rows(asm, idx: np.ndarray) -> np.ndarray:
    """The member index (in asm.mesh.members' order) of each element row of idx, by its first coordinate."""
    starts = np.array([mm.offset for mm in asm.mesh.members.values()])
    return np.searchsorted(starts, idx[:, 0], side="right") - 1


def member_betas(S) -> np.ndarray:
    """beta of each member (asm.mesh.members' order) as the run applies it: beta_ref times its elements' weight."""
    asm, ray = S.asm, S.rayleigh
    out = np.zeros(len(asm.mesh.members))
    for ti, w in ray.element_weight.items():
        m = member_of_rows(asm, S.nonlinear[ti].term.idx)
        out[m] = ray.beta * np.asarray(w, float) * np.ones(len(m))
    return out


def beta_entry(scene, members: list[str]) -> np.ndarray:
    """Per member (in the given order): the index i of the [[dampings]] entry whose beta it takes (-1: none)."""
    out = np.full(len(members), -1)
    for i, d in enumerate(scene.dampings):  # (the reader adds one Damping per entry, in order; later ones win)
        if d.kind == "rayleigh" and d.beta:
            names = set(d.members or scene.members)
            out[[k for k, name in enumerate(members) if name in names]] = i
    return out


def weighted_rows(asm, idx: np.ndarray, coef: np.ndarray) -> list[tuple[np.ndarray, float]]:
    """(rows, c): the element rows of idx grouped by their member's coefficient c (coef per member), c != 0."""
    c = coef[member_of_rows(asm, idx)]
    return [(np.flatnonzero(c == v), float(v)) for v in np.unique(c) if v != 0.0]


def beta_pieces(S, scene, i: int | None, pieces) -> list[tuple]:
    """(element, effect, gauss, idx, P, c) of d(C's elastic part)/dp as kernels' Hessians: for dampings[i].beta
    (i given) the elastic terms on the members entry i gives their beta, c = 1; for a model parameter (i None)
    the derivative's elastic pieces, c = their member's beta."""
    asm = S.asm
    if i is not None:
        coef = (beta_entry(scene, list(asm.mesh.members)) == i).astype(float)
        src = [mk.term for ti, mk in enumerate(S.nonlinear) if ti in S.rayleigh.element_weight and
               mk.term.label in ELASTIC_LABELS]
    else:
        coef = member_betas(S)
        src = [pc for pc in pieces if pc.label in ELASTIC_LABELS]
    out = []
    for t in src:
        for rows, c in weighted_rows(asm, t.idx, coef):
            out.append((t.element, t.effect, t.gauss, t.idx[rows], np.asarray(t.P, float)[rows], c))
    return out
