"""Energy terms of a meshed scene: one (element kind, effect) kernel applied to a set of elements.

Only the effects a member asks for with non-zero stiffness become terms: a scene without bending never loads
or calls a bending kernel. Each term carries the label of the energy bucket it reports into.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ancf_sym.contact import laws as contact
from ancf_sym.model.mesh import Mesh, MemberMesh
from ancf_sym.scene.member_effects import stiffness_effects
from ancf_sym.scene.builder import SceneError, Section
from ancf_sym.scene.water import net_weight_density


@dataclass
class Term:
    label: str  # energy bucket: axial, bending, torsion, continuum, gravity, loads
    element: str
    effect: str
    gauss: int | None
    idx: list = field(default_factory=list)  # per element: global coordinate indices
    P: list = field(default_factory=list)  # per element: kernel parameters

    @property
    def key(self) -> tuple:
        return (self.label, self.element, self.effect, self.gauss)


def _add(terms: dict, label, element, effect, gauss, idx_rows, p_rows):
    t = terms.setdefault((label, element, effect, gauss), Term(label, element, effect, gauss))
    t.idx.append(np.asarray(idx_rows, dtype=np.int64))  # (blocks of rows, stacked once by scene_terms)
    t.P.append(np.asarray(p_rows, dtype=float))


def member_terms(terms: dict, mm: MemberMesh, gravity: np.ndarray, water=None) -> None:
    m = mm.member
    idx, L = mm.elem_dofs(), mm.elem_length
    idx.flags.writeable = False  # (shared by the member's terms)
    E, A, nu, sec = m.material.E, m.section.area, m.material.nu, m.section
    try:
        effects = stiffness_effects(m.element, m.axial, m.bending, m.torsion, m.beam_method)
    except SceneError as exc:
        raise SceneError(f"member {m.name!r}: {exc}") from None

    def params(*values: float) -> np.ndarray:
        """Per element (L, *values): the element's length, then the member's values."""
        P = np.empty((len(L), 1 + len(values)))
        P[:, 0] = L
        P[:, 1:] = values
        return P
    for label, effect in effects:
        if effect == "continuum":
            # St. Venant's torsion constant: the section's J, else that of the b x h rectangle
            J = sec.J if sec.J is not None else Section.rectangle(sec.b, sec.h).J
            p = params(sec.b, sec.h, E, nu, J)
        elif effect == "line_strain":
            p = params(sec.b, sec.h, E, nu)
        elif effect == "line_bending":
            p = params(E * sec.Iy, E * sec.Iz)
        elif effect == "line_torsion":
            p = params(m.material.shear_modulus * sec.J)
        elif effect == "bending":
            p = params(E * sec.bending_inertia)
        else:  # a cable's axial strain measure
            p = params(E * A)
        # (Scene.member checked the Gauss order against the effects; the continuum kernel has only its own)
        _add(terms, label, m.element, effect, None if effect == "continuum" else m.gauss, idx, p)
    if m.gravity and any(gravity):
        # (in water: the weight less the displaced water's, ancf_sym.scene.water)
        _add(terms, "gravity", m.element, "gravity", None, idx, params(net_weight_density(water, m), *gravity))
    if m.arc_curvature is not None and m.bending:
        curved_reference_term(terms, mm)


def curved_reference_term(terms: dict, mm: MemberMesh) -> None:
    """The bending of a planar arc (Scene.arc) measured from its curved reference: the cable's bending energy
    1/2 int EI k^2 dx (k the curvature, x the material coordinate) plus the potential -M (phi_end - phi_start) of
    the tangent's turn (the moment kernel's -M phi, phi from the reference tangent): M at the end, -M at the start.
    For a uniform arc of material length L, stretch lam and curvature k (turn k lam L) the energy
    L (EA/2 eps(lam)^2 + EI/2 k^2) - M k lam L is stationary at k = M lam / EI and EA eps eps' = EI k^2 / lam: with
    M = EI k0 / lam and the member's stretch lam = 1 + prestrain solving the second (Scene.arc; lam - 1 ~ EI k0^2 /
    EA, 2.5e-5 for a 20 mm rod on a 1 m radius) the drawn arc is the unloaded equilibrium, exactly in the limit of
    fine meshes. Reported with the bending energy (phi counts from the reference tangents: the bending energy is
    the straight-state measure, EI k0^2 L / 2 in the drawn arc)."""
    m = mm.member
    M = m.material.E * m.section.bending_inertia * m.arc_curvature / (1.0 + m.prestrain)
    L = mm.elem_length
    last = mm.n_nodes - 1
    for node, e, xi, sign in ((0, 0, 0.0, -1.0), (last, len(L) - 1, 1.0, 1.0)):
        t0 = mm.x0[node][2:4]
        _add(terms, "bending", "cable2d", "moment", None, [mm.elem_dofs()[e]], [[L[e], xi, sign * M, t0[0], t0[1]]])


def distributed_term(terms: dict, mm: MemberMesh, f: np.ndarray) -> None:
    """A dead distributed load is the gravity kernel with rhoA = 1 and g = f [N/m]."""
    L = mm.elem_length
    _add(terms, "loads", mm.member.element, "gravity", None, mm.elem_dofs(), np.c_[L, np.ones_like(L), np.tile(f, (len(L), 1))])


def moment_term(terms: dict, mm: MemberMesh, node: int, moment) -> None:
    """Work-conjugate moment at a node: the element ending (or starting) there, xi = 1 (or 0)."""
    m = mm.member
    e, xi = (node - 1, 1.0) if node > 0 else (0, 0.0)
    idx, L = mm.elem_dofs()[e], mm.elem_length[e]
    ref = mm.x0[node]
    if m.element == "cable2d":
        t0 = ref[2:4]
        _add(terms, "loads", "cable2d", "moment", None, [idx], [[L, xi, float(moment), t0[0], t0[1]]])
    elif m.element == "cable3d":
        M = np.asarray(moment, float)
        mag = np.linalg.norm(M)
        if mag == 0:
            return
        t0 = ref[3:6]
        along = float(np.dot(M, t0 / np.linalg.norm(t0)))
        if abs(along) > 1e-9 * mag:
            # the potential -|M| phi turns the tangent about n = M/|M|; only a moment normal to the tangent is
            # work-conjugate to that rotation (a cable has no torsion to take the rest)
            raise SceneError(f"moment on cable3d member {m.name!r}: component {along:.6g} N m along the cable axis; "
                             "a cable carries no torsion: give a moment normal to the cable")
        _add(terms, "loads", "cable3d", "moment", None, [idx], [[L, xi, mag, *(M / mag), *t0]])
    else:
        M = np.asarray(moment, float)
        ry, rz = ref[6:9], ref[9:12]
        if M[2] != 0:
            _add(terms, "loads", "beam3d", "moment_z", None, [idx], [[L, xi, M[2], ry[0], ry[1]]])
        if M[1] != 0:
            _add(terms, "loads", "beam3d", "moment_y", None, [idx], [[L, xi, M[1], rz[2], rz[0]]])


def scene_terms(mesh: Mesh) -> list[Term]:
    scene = mesh.scene
    terms: dict = {}
    for mm in mesh.members.values():
        member_terms(terms, mm, scene.gravity, getattr(scene, "water", None))
    for load in scene.loads:
        mm = mesh.members[load.member]
        if load.kind == "distributed":
            distributed_term(terms, mm, load.value)
        elif load.kind == "moment":
            moment_term(terms, mm, mm.node(load.at), load.value)
    contact.energy_terms(terms, mesh, _add)
    out = list(terms.values())
    for t in out:  # (a term of one member keeps its blocks: the terms of a member share its idx, read only)
        t.idx, t.P = (t.idx[0], t.P[0]) if len(t.idx) == 1 else (np.concatenate(t.idx), np.concatenate(t.P))
    return out
