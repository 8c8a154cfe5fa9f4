"""The exact derivative of the assembled model with respect to one scene parameter (a TOML path), at a state x.

The residual of the statics is R(x, p) = grad Pi(x, p) = sum_terms grad U_t(x; P_t(p)) - Q(p). Each kernel's energy
is linear in a group of its parameters (its coefficients: EA of an axial kernel, EI of bending, (EIy, EIz) of the
elastic line's bending, E of the line strain, the force or moment of a load, rhoA or the gravity vector g of the
gravity kernel, (k, kh) of a contact law), so that dU/dp = U(x; P with that group replaced by d(group)/dp): the
kernel evaluated with its coefficients' derivatives gives the exact derivative of its energy, gradient and Hessian
(no difference quotient). The scene's numbers enter those coefficients as monomials (EA = E area, EI = E I with
I = pi d^4 / 64 of a diameter d, rhoA = density area, G J = E J / (2 (1 + nu))): a coefficient c of degree k in p
has dc/dp = k c / p. A cable member's prestrain enters through its elements' reference length L, whose derivative
follows exactly from the kernels' outputs by a change of the unit of length (ancf_sym.sensitivity.length_derivative).
Where a scene number enters a kernel's parameters nonlinearly (a beam3d member's Poisson ratio, E with G given,
its section's b x h; a penalty contact's drum radius and centre, ground level and thickness), the rows' derivative
dP/dp is exact (ancf_sym.sensitivity.beam_rows) and the kernel's compiled parameter-direction companion gives
d/dP [U, grad U, H] . dP (ancf_sym.sensitivity.kernel_direction). Parameters that enter anywhere else (an arc's
reference moment, an exact contact's geometry) are refused by name.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
import tomllib
from pathlib import Path
from typing import Callable

import casadi as ca
import numpy as np
import scipy.sparse as sp

from ancf_sym import kernels, registry
from ancf_sym.model.assembly import Assembly
from ancf_sym.model.loads import load_vector, point_mass_triplets
from ancf_sym.model.terms import distributed_term, moment_term
from ancf_sym.scene.builder import Scene
from ancf_sym.sensitivity.body_derivative import body_derivative
from ancf_sym.sensitivity.beam_rows import MATERIAL_KEYS, base_derivatives, mass_direction, row_derivative
from ancf_sym.sensitivity.kernel_direction import DirectionPiece
from ancf_sym.sensitivity.length_derivative import mass_derivative, prestrain_pieces, prestrain_refusal
from ancf_sym.sensitivity.paths import ParameterPath, get_parameter, parse_path
from ancf_sym.sensitivity.water_derivative import WaterTerms, gravity_pieces, water_tangent

STIFFNESS_COLUMNS = {  # effect -> its coefficient columns (the energy is linear in them jointly)
    "axial_green": ("EA",), "axial_biot": ("EA",), "axial_decoupled": ("EA",), "axial_decoupled_biot": ("EA",),
    "bending": ("EI",), "line_bending": ("EIy", "EIz"), "line_torsion": ("GIp",), "line_strain": ("E",),
    "continuum": ("E",),
}
NOT_STIFFNESS = ("gravity", "loads", "contact", "penalty")  # energy labels that hold no member stiffness


class ParameterError(ValueError):
    """A parameter path this model cannot differentiate; the message names the path and why."""


@dataclass
class Piece:
    """Kernel calls whose outputs are the derivative: the kernel (element, effect, gauss) on elements idx with
    parameter rows P (the coefficient group replaced by its derivative)."""
    element: str
    effect: str
    gauss: int | None
    idx: np.ndarray  # (N, nd)
    P: np.ndarray  # (N, np)
    label: str = ""  # the energy bucket it belongs to (axial, bending, gravity, loads, contact, ...)

    def grad(self, x: np.ndarray) -> tuple[float, np.ndarray]:
        """(d energy/dp summed over the elements, d gradient/dp per element (N, nd))."""
        e, g = (o.full() for o in _mapped_grad(self.element, self.effect, self.gauss, len(self.idx))(
            x[self.idx].T, self.P.T))
        return float(e.sum()), g.T

    def hessian(self, x: np.ndarray) -> np.ndarray:
        """d Hessian/dp per element (N, nd, nd)."""
        N, nd = self.idx.shape
        if self.effect == "gravity":  # linear in q: no Hessian
            return np.zeros((N, nd, nd))
        H = _mapped(self.element, self.effect, self.gauss, N)(x[self.idx].T, self.P.T)[2].full()
        return H.reshape(nd, N, nd).transpose(1, 0, 2)  # (blocks side by side)


@dataclass
class ModelDerivative:
    """d/dp of the model: kernel pieces (energy, gradient, Hessian), the dead load dQ (potential -Q.x) and the mass
    matrix dM (None: the mass does not depend on p)."""
    path: str
    value: float
    pieces: list = field(default_factory=list)
    dQ: np.ndarray | None = None
    mass: Callable[[], sp.csc_matrix] | None = field(default=None, repr=False)  # builds dM where the mass depends on p
    water: WaterTerms | None = field(default=None, repr=False)  # lines in water: the water's terms' derivative

    @property
    def dM(self) -> sp.csc_matrix | None:
        """d M / dp (None: the mass does not depend on p), built on first use (statics never needs it)."""
        if self.mass is not None and not hasattr(self, "_dM"):
            self._dM = self.mass()
        return getattr(self, "_dM", None)

    @property
    def constant_residual(self) -> bool:
        """d grad Pi/dp does not depend on x: dead loads and the gravity kernel (linear in q) only."""
        return self.water is None and all(pc.effect == "gravity" for pc in self.pieces)

    def residual(self, x: np.ndarray) -> tuple[float, np.ndarray]:
        """(d Pi/dp, d grad Pi/dp) at fixed x (full coordinates)."""
        n = len(x)
        dPi, dR = 0.0, np.zeros(n)
        for pc in self.pieces:
            e, g = pc.grad(x)
            dPi += e
            dR += np.bincount(pc.idx.ravel(), g.ravel(), minlength=n)
        if self.dQ is not None:
            dPi -= float(self.dQ @ x)
            dR -= self.dQ
        if self.water is not None:  # (the water line's potential; the drag and water line's forces)
            dU, dr = self.water.residual(x)
            dPi, dR = dPi + dU, dR + dr
        return dPi, dR

    def energies(self, x: np.ndarray) -> dict:
        """label -> d(energy of that label)/dp at fixed x (the dead loads' -dQ.x under "loads")."""
        out: dict = {}
        for pc in self.pieces:
            out[pc.label] = out.get(pc.label, 0.0) + pc.grad(x)[0]
        if self.dQ is not None and np.any(self.dQ):
            out["loads"] = out.get("loads", 0.0) - float(self.dQ @ x)
        if self.water is not None:  # (a result in water books the water line under gravity)
            out["gravity"] = out.get("gravity", 0.0) + self.water.residual(x)[0]
        return out

    def hessian_vector(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """(d K / dp at fixed x) u on the full coordinates: the pieces' Hessians times u, scattered."""
        out = np.zeros(len(x))
        for pc in self.pieces:
            if pc.effect == "gravity":
                continue
            Hb = pc.hessian(x)
            out += np.bincount(pc.idx.ravel(), np.einsum("eij,ej->ei", Hb, u[pc.idx]).ravel(), minlength=len(x))
        if self.water is not None:
            out += self.water.hessian_vector(x, u)
        return out

    def hessian_form(self, x: np.ndarray, u: np.ndarray, v: np.ndarray) -> float:
        """u' (d K / dp at fixed x) v: the kernels' Hessians of the pieces (dQ adds none)."""
        out = 0.0
        for pc in self.pieces:
            if pc.effect == "gravity":  # linear in q: no Hessian
                continue
            out += float(np.einsum("ei,eij,ej->", u[pc.idx], pc.hessian(x), v[pc.idx]))
        if self.water is not None:
            out += self.water.hessian_form(x, u, v)
        return out


_MAPS: dict = {}


def _mapped_grad(element, effect, gauss, N) -> ca.Function:
    key = ("grad", element, effect, gauss, N)
    if key not in _MAPS:
        _MAPS[key] = kernels.load_grad(element, effect, gauss).map(N)
    return _MAPS[key]


def _mapped(element, effect, gauss, N) -> ca.Function:
    key = ("full", element, effect, gauss, N)
    if key not in _MAPS:
        _MAPS[key] = kernels.load(element, effect, gauss).map(N)
    return _MAPS[key]


# -- which members a material or section reaches ----------------------------------------------------------------------
def _members_with(doc: dict, key: str, name: str) -> list[str]:
    out = []
    for kind in ("members", "loops"):
        for d in doc.get(kind, []):
            if d.get(key) == name:
                out.append(d["name"])
    return out


def _member_rows(asm: Assembly, term, members: list[str]) -> np.ndarray:
    """Rows (elements) of a term that belong to the named members (by their first coordinate's owner)."""
    first = term.idx[:, 0]
    mask = np.zeros(len(first), bool)
    for name in members:
        mm = asm.mesh.members[name]
        mask |= (first >= mm.offset) & (first < mm.offset + mm.x0.size)
    return mask


def _scaled_pieces(asm: Assembly, members: list[str], degrees: dict, value: float, path: str,
                   labels: tuple) -> list[Piece]:
    """Pieces of the terms with label in `labels` (None: the stiffness labels) on `members`: each coefficient
    column c named in `degrees` (column -> degree of p in it) replaced by degree c / p, the effect's other
    coefficient columns set to zero (their share of the derivative is nil)."""
    pieces = []
    for t in asm.terms:
        stiff = t.label not in NOT_STIFFNESS and not t.label.startswith("contact")
        if (labels is None and not stiff) or (labels is not None and t.label not in labels):
            continue
        rows = _member_rows(asm, t, members)
        if not rows.any():
            continue
        names = kernels.parameters(t.element, t.effect)
        group = STIFFNESS_COLUMNS.get(t.effect, ("rhoA",) if t.effect == "gravity" else None)
        if group is None:
            raise ParameterError(f"parameter path {path!r}: enters the {t.effect!r} energy of {t.element} members "
                                 f"{members}, whose kernel has no derivative with respect to it")
        P = np.array(t.P[rows], float)
        hit = False
        for c in group:
            j = names.index(c)
            k = degrees.get(c, 0)
            P[:, j] = k * P[:, j] / value if k else 0.0
            hit |= bool(k)
        if hit:
            pieces.append(Piece(t.element, t.effect, t.gauss, t.idx[rows], P, t.label))
    return pieces


def _element_matrices(asm: Assembly, members: list[str], matrix: Callable) -> sp.csc_matrix:
    """The sum over the members' elements of matrix(member, [L, *mass parameters]) scattered to their coordinates
    (mass parameters: cables rho A, beam3d b, h, rho)."""
    rows, cols, vals = [], [], []
    for name in members:
        mm = asm.mesh.members[name]
        idx = mm.elem_dofs()
        m = mm.member
        mp = [m.section.b, m.section.h, m.material.density] if m.element == "beam3d" else \
            [m.material.density * m.section.area]
        nd = idx.shape[1]
        for e, L in enumerate(np.asarray(mm.elem_length, float)):
            rows.append(np.repeat(idx[e], nd))
            cols.append(np.tile(idx[e], nd))
            vals.append(np.asarray(matrix(name, [float(L), *mp])).ravel())
    n = asm.n
    if not vals:
        return sp.csc_matrix((n, n))
    return sp.csc_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))


def _mass_derivative(asm: Assembly, members: list[str], degree: int) -> sp.csc_matrix:
    """d M / dp where every listed member's rhoA has degree `degree` in p (the mass kernels are linear in rho A
    (cables) and in rho (beam3d: L, b, h, rho))."""
    return degree * _element_matrices(asm, members, lambda name, p: kernels.mass_matrix(
        asm.mesh.members[name].member.element, p))


def _term_pieces(add: Callable, *args) -> list[Piece]:
    """Pieces of the terms a terms.py builder (distributed_term, moment_term) makes with unit values."""
    tmp: dict = {}
    add(tmp, *args)
    return [Piece(t.element, t.effect, t.gauss, np.concatenate(t.idx), np.concatenate(t.P), t.label)
            for t in tmp.values()]


def _refuse_arcs(asm: Assembly, members: list[str], path: str) -> None:
    for name in members:
        if asm.mesh.members[name].member.arc_curvature is not None:
            raise ParameterError(f"parameter path {path!r}: reaches the arc {name!r}, whose prestrain and reference "
                                 "moment depend on it nonlinearly (not differentiable here)")


def model_derivative(asm: Assembly, doc: dict, path: str | ParameterPath) -> ModelDerivative:
    """d(model)/dp for p the number at `path` of the scene document `doc` that `asm` was built from (lines in
    water: with the water's terms, ancf_sym.sensitivity.water_derivative)."""
    if getattr(asm.scene, "water", None) is None:
        return _dry_model_derivative(asm, doc, path)
    p = path if isinstance(path, ParameterPath) else parse_path(path)
    value = get_parameter(doc, p)

    def refuse(why: str):
        raise ParameterError(f"parameter path {p.text!r} = {value!r}: {why}")
    tan = water_tangent(asm, doc, p.keys, value, refuse)
    out = ModelDerivative(p.text, value) if p.keys[0] == "water" else _dry_model_derivative(asm, doc, p)
    if p.keys == ("water", "seabed", "stiffness"):  # (the seabed's ground contacts: the law linear in k)
        out.pieces = _seabed_pieces(asm, doc)
        return out
    if tan.dnet:  # (the gravity kernel carries the net weight rho A - rho_w A_displaced)
        out.pieces = [pc for pc in out.pieces if pc.effect != "gravity"] + gravity_pieces(asm, tan, Piece)
    terms = WaterTerms(asm, tan)
    if tan.moves_water_terms():
        out.water = terms
    if terms.added_mass_moves():  # (the added mass at the state the dynamics' mass matrix takes it)
        dry, state = out.mass, getattr(asm, "added_mass_state", None)
        xm = asm.x0 if state is None else np.asarray(state, float)
        out.mass = lambda: terms.mass(xm) if dry is None else (dry() + terms.mass(xm)).tocsc()
    return out


def _seabed_pieces(asm: Assembly, doc: dict) -> list[Piece]:
    """The seabed's contact kernels with their stiffness column 1 (the document's own contacts come first in the
    scene, then one ground contact per wet member)."""
    from ancf_sym.contact import laws as contact
    calls: list = []  # (the penalty contacts' normal-law kernel calls, in declaration order)
    contact.energy_terms({}, asm.mesh, lambda _t, _label, *call: calls.append(call))
    penalty = [k for k in asm.scene.contacts if k.method == "penalty"]
    seabed = set(map(id, asm.scene.contacts[len(doc.get("contacts", [])):]))
    out = []
    for c, (element, effect, gauss, idx, P) in zip(penalty, calls):
        if id(c) in seabed:
            names = kernels.parameters(element, effect)
            P = np.array(P, float)
            P[:, names.index("k")] = 1.0
            P[:, names.index("kh")] = 0.0
            out.append(Piece(element, effect, gauss, np.asarray(idx), P, "contact"))
    return out


def _dry_model_derivative(asm: Assembly, doc: dict, path: str | ParameterPath) -> ModelDerivative:
    """model_derivative of the model's kernels and loads (the water's terms aside)."""
    p = path if isinstance(path, ParameterPath) else parse_path(path)
    value = get_parameter(doc, p)
    keys, text = p.keys, p.text
    out = ModelDerivative(text, value)
    scene = asm.scene

    def refuse(why: str):
        raise ParameterError(f"parameter path {text!r} = {value!r}: {why}")

    if keys[0] in ("materials", "sections") and asm.penalty is not None and keys[-1] != "density":
        refuse("the scene's penalty supports and joints take their stiffness from EA and EI (k = EA / 1 m, "
               "EI / 1 m): give them method = \"exact\" to differentiate a stiffness")
    if keys[0] == "materials" and len(keys) == 3:
        members = _members_with(doc, "material", keys[1])
        _refuse_arcs(asm, members, text)
        beams = [m for m in members if scene.members[m].element == "beam3d"]
        if keys[2] in MATERIAL_KEYS and beams:
            out.pieces, out.mass = _beam_pieces(asm, doc, beams, keys[2], None, text, refuse)
        if keys[2] == "E":
            degrees = {c: 1 for cols in STIFFNESS_COLUMNS.values() for c in cols}
            if "G" in doc["materials"][keys[1]]:  # a given shear modulus: GJ does not scale with E
                degrees["GIp"] = 0
            cables = [m for m in members if m not in beams]
            out.pieces += _scaled_pieces(asm, cables, degrees, value, text, None) if cables else []
        elif keys[2] in ("poisson", "G"):
            pass  # (a cable's kernels take neither: only the beams' pieces)
        elif keys[2] == "density":
            grav = [m for m in members if scene.members[m].gravity]
            out.pieces = _scaled_pieces(asm, grav, {"rhoA": 1}, value, text, ("gravity",))
            out.mass = (lambda: _mass_derivative(asm, members, 1) / value) if members else None
        else:
            refuse("enters the model nonlinearly or not at all (differentiable material keys: E, density, poisson, G)")
        return out
    if keys[0] == "sections" and len(keys) == 3:
        sec = doc["sections"][keys[1]]
        members = _members_with(doc, "section", keys[1])
        _refuse_arcs(asm, members, text)
        beams = [m for m in members if scene.members[m].element == "beam3d"]
        if beams:
            if len(beams) < len(members):
                refuse("a section used by beam3d members and cables is not differentiated")
            out.pieces, out.mass = _beam_pieces(asm, doc, beams, keys[2], sec.get("shape"), text, refuse,
                                                tuple(sec))
            return out
        # (contacts that take their thickness from the section: a cable's radius sqrt(area / pi))
        thick = [c for i, c in enumerate(getattr(scene, "contacts", ()))
                 if c.member in members and i < len(doc.get("contacts", []))
                 and "thickness" not in doc["contacts"][i]]  # (the seabed's contacts, after the document's, take water.seabed.thickness)
        for c in thick:
            if c.method != "penalty":
                refuse(f"the exact contact on member {c.member!r} takes its thickness from the section (give the "
                       "contact a thickness to differentiate the section)")
        shape = sec.get("shape")
        if shape is None and keys[2] == "area":
            deg = {"EA": 1, "rhoA": 1, "mass": 1}
        elif shape is None and keys[2] == "I" and not ({"Iy", "Iz"} & set(sec)):
            deg = {"EI": 1}
        elif shape == "circle" and keys[2] == "diameter":
            deg = {"EA": 2, "EI": 4, "rhoA": 2, "mass": 2}
        else:
            refuse("differentiable section keys: area, I (cables, without Iy/Iz), diameter (circle)")
        out.pieces = _scaled_pieces(asm, members, deg, value, text, None)
        grav = [m for m in members if scene.members[m].gravity]
        out.pieces += _scaled_pieces(asm, grav, deg, value, text, ("gravity",))
        for c in thick:  # (t = sqrt(area / pi) has half the area's degree in p)
            out.pieces += _contact_pieces(asm, c, {"t": deg.get("rhoA", 0) / 2 * c.thickness / value}, text, refuse)
        if deg.get("mass"):
            out.mass = lambda: _mass_derivative(asm, members, deg["mass"]) / value
        return out
    if keys[:2] == ("scene", "gravity") and len(keys) == 3:
        j = keys[2]
        for t in asm.terms:
            if t.label != "gravity":
                continue
            names = kernels.parameters(t.element, t.effect)
            P = np.array(t.P, float)
            gcols = [names.index(c) for c in names if c in ("gx", "gy", "gz")]
            P[:, gcols] = 0.0
            P[:, gcols[j]] = 1.0
            out.pieces.append(Piece(t.element, t.effect, t.gauss, t.idx, P, t.label))
        e = np.zeros(scene.dim)
        e[j] = 1.0
        dQ = load_vector(_MeshView(asm.mesh, gravity=e, point_masses=getattr(scene, "point_masses", ())))
        for name, o in asm.mesh.bodies.items():  # bodies: m g at the centre of mass (its coordinates first)
            dQ[o + j] += scene.bodies[name].mass
        out.dQ = dQ
        return out
    if keys[0] == "loads" and len(keys) in (3, 4) and keys[2] == "value":
        load = scene.loads[keys[1]]
        mm = asm.mesh.members[load.member]
        if load.kind == "tension" and len(keys) == 3:  # (the dead force is linear in the tension)
            out.dQ = load_vector(_MeshView(asm.mesh, [replace(load, value=1.0)]))
            return out
        if len(keys) == 3:
            if load.kind == "moment" and scene.dim == 2:
                out.pieces = _term_pieces(moment_term, mm, mm.node(load.at), 1.0)
                return out
            refuse("name one component: loads[i].value[j]")
        e = np.zeros(scene.dim if load.kind != "moment" else 3)
        e[keys[3]] = 1.0
        if load.kind == "force":
            out.dQ = load_vector(_MeshView(asm.mesh, [replace(load, value=e)]))
        elif load.kind == "distributed":
            out.pieces = _term_pieces(distributed_term, mm, e)
        elif load.kind == "moment" and mm.member.element == "beam3d":
            out.pieces = _term_pieces(moment_term, mm, mm.node(load.at), e)
        else:
            refuse("a cable3d moment's potential is not linear in its components (not differentiable here)")
        return out
    if keys[0] == "masses" and len(keys) == 3 and keys[2] == "mass":
        unit = replace(scene.point_masses[keys[1]], mass=1.0)  # (weight and mass matrix linear in the mass)
        view = _MeshView(asm.mesh, gravity=np.asarray(scene.gravity, float), point_masses=[unit])
        out.dQ = load_vector(view)
        r, c, v = point_mass_triplets(view)
        out.mass = lambda: sp.csc_matrix((v, (r, c)), shape=(asm.n, asm.n))
        return out
    if keys[0] == "bodies" and len(keys) >= 3:
        out.dQ, out.mass = body_derivative(asm, doc, keys, refuse)
        return out
    if keys[0] == "contacts" and len(keys) == 3 and keys[2] in ("stiffness", "hertz"):
        c = scene.contacts[keys[1]]
        if c.method != "penalty":
            refuse("an exact contact has no stiffness")
        element, effect, gauss, idx, P = _penalty_call(asm, c)
        names = kernels.parameters(element, effect)
        P = np.array(P, float)
        P[:, names.index("k")] = 1.0 if keys[2] == "stiffness" else 0.0  # (the law is linear in k and kh jointly)
        P[:, names.index("kh")] = 1.0 if keys[2] == "hertz" else 0.0
        out.pieces = [Piece(element, effect, gauss, np.asarray(idx), P, "contact")]
        return out
    if keys[0] == "contacts" and len(keys) == 3 and keys[2] in ("mu", "damping"):
        # (the dissipation acts on velocities: at rest it is zero whatever mu and c, so an equilibrium and its
        # undamped frequencies have derivative exactly zero; refused rather than a zero column that a calibration
        # cannot use. Dynamics: ancf_sym.sensitivity.contact_dissipation)
        refuse("friction and contact damping act on velocities only: a static equilibrium and its undamped "
               "frequencies do not depend on them (the derivative is zero); differentiate them in a dynamics run")
    if keys[0] == "contacts" and len(keys) == 3 and keys[2] == "eps":
        refuse("the friction's regularisation velocity enters its force nonlinearly (not differentiable here)")
    if keys[0] == "contacts" and (keys[2:] in (("radius",), ("level",), ("thickness",)) or
                                  (len(keys) == 4 and keys[2] == "centre")):
        c = scene.contacts[keys[1]]
        col = {"radius": "R", "level": "d", "thickness": "t"}.get(keys[2]) or "c" + "xyz"[keys[3]]
        out.pieces = _contact_pieces(asm, c, {col: 1.0}, text, refuse)
        return out
    if keys[0] == "contacts" and len(keys) == 4 and keys[2] == "normal":
        # the kernel takes the unit normal n = v / |v| of the file's v: dn/dv_j = (e_j - n n_j) / |v|
        v = np.asarray(doc["contacts"][keys[1]]["normal"], float)
        n = v / np.linalg.norm(v)
        dn = (np.eye(len(v))[keys[3]] - n * n[keys[3]]) / np.linalg.norm(v)
        cols = {"n" + a: float(d) for a, d in zip("xyz", dn)}
        out.pieces = _contact_pieces(asm, scene.contacts[keys[1]], cols, text, refuse)
        return out
    if keys[0] in ("members", "loops") and len(keys) == 3 and keys[2] == "prestrain":
        name = doc[keys[0]][keys[1]]["name"]
        why = prestrain_refusal(asm, name)
        if why is not None:
            refuse(why)
        out.pieces = prestrain_pieces(asm, name, value)
        out.mass = lambda: mass_derivative(asm, [name], -1.0 / (1.0 + value))
        return out
    refuse("not a differentiable parameter here (materials.M.E | density | poisson | G, sections.S.area | I | "
           "diameter | b | h, scene.gravity[j], loads[i].value[j], masses[i].mass, bodies[i].mass | inertia | "
           "force[j], contacts[i].stiffness | hertz | mu | damping | radius | centre[j] | level | normal[j] | "
           "thickness, members[i].prestrain, loops[i].prestrain, water.*: see docs/sensitivity.md)")


# -- parameters that enter kernels nonlinearly: the rows' derivative dP and the kernels' direction companions ------
def _direction(element: str, effect: str, gauss, idx: np.ndarray, P: np.ndarray, dP: np.ndarray, label: str,
               text: str) -> list:
    """The pieces of one kernel call whose parameter rows P change by dP per unit p: a Piece where only columns of
    the kernel's linear coefficient group change (the kernel evaluated with the group replaced by its derivative),
    else a DirectionPiece (the compiled companion's d/dP . dP); refused where the kernel has no companion."""
    nz = np.flatnonzero(np.any(dP != 0.0, axis=0))
    if not len(nz):
        return []
    names = kernels.parameters(element, effect)
    group = STIFFNESS_COLUMNS.get(effect, ("rhoA",) if effect == "gravity" else ())
    if {names[j] for j in nz} <= set(group):
        Pg = np.array(P, float)
        for c in group:
            Pg[:, names.index(c)] = dP[:, names.index(c)]
        return [Piece(element, effect, gauss, idx, Pg, label)]
    if registry.has_parameter_direction(element, effect, gauss):
        return [DirectionPiece(element, effect, gauss, idx, np.array(P, float), dP, label)]
    raise ParameterError(f"parameter path {text!r}: changes {[names[j] for j in nz]} of the {element}/{effect} "
                         f"kernel (gauss {gauss}), which enter it nonlinearly, and that kernel has no compiled "
                         "parameter-direction companion (registry.PARAMETER_DIRECTION_EFFECTS: beams at their default "
                         "Gauss order)")


def _penalty_call(asm: Assembly, c) -> tuple:
    """(element, effect, gauss, idx, P) of a penalty contact's normal-law kernel call."""
    from ancf_sym.contact import laws as contact
    calls: list = []  # (the penalty contacts' normal-law kernel calls, in declaration order)
    contact.energy_terms({}, asm.mesh, lambda _t, _label, *call: calls.append(call))
    penalty = [k for k in asm.scene.contacts if k.method == "penalty"]
    return calls[next(i for i, k in enumerate(penalty) if k is c)]


def _contact_pieces(asm: Assembly, c, columns: dict, text: str, refuse: Callable) -> list:
    """Pieces of a penalty contact whose kernel parameters `columns` (name -> d/dp) change."""
    if c.method != "penalty":
        refuse("an exact contact's geometry sits in its unilateral rows, not in the model: differentiated in statics "
               "only (StaticSensitivity, sensitivities() without modes, `ancf-sym run` of a statics analysis: a "
               "fixed drum's radius, centre, a ground's level, a thickness); elsewhere give the contact a "
               "stiffness: method = \"penalty\"")
    if c.dissipative:
        refuse("the contact's damping and friction forces depend on its geometry too (not differentiated here)")
    if getattr(c, "body", None) is not None:
        refuse("a drum carried by a body: its geometry enters the body's kernels (not differentiated here)")
    element, effect, gauss, idx, P = _penalty_call(asm, c)
    names = kernels.parameters(element, effect)
    P = np.array(P, float)
    dP = np.zeros_like(P)
    for name, v in columns.items():
        dP[:, names.index(name)] = v
    return _direction(element, effect, gauss, np.asarray(idx), P, dP, "contact", text)


def _beam_pieces(asm: Assembly, doc: dict, beams: list[str], key: str, shape: str | None, text: str,
                 refuse: Callable, given: tuple = ()) -> tuple[list, Callable | None]:
    """(pieces, mass derivative builder or None) of beam3d members for their material's E | poisson | G or their
    section's b | h (ancf_sym.sensitivity.beam_rows)."""
    scene = asm.scene
    if getattr(scene, "water", None) is not None:
        refuse("the beam's buoyancy and added mass in water are not differentiated with respect to it")
    pieces, masses = [], {}
    for name in beams:
        m = scene.members[name]
        d = base_derivatives(m, key, shape, given)
        if isinstance(d, str):
            refuse(d)
        for t in asm.terms:
            if t.label.startswith("contact") or (t.effect == "gravity" and t.label != "gravity"):
                continue  # (contacts below; a distributed load uses the gravity kernel)
            rows = _member_rows(asm, t, [name])
            if not rows.any():
                continue
            P = np.array(t.P[rows], float)
            dp = row_derivative(t.effect, m, d, P.shape[1])
            if dp is None:
                continue
            pieces += _direction(t.element, t.effect, t.gauss, t.idx[rows], P, np.tile(dp, (len(P), 1)), t.label,
                                 text)
        for i, c in enumerate(getattr(scene, "contacts", ())):
            if c.member == name and d["h"] and "thickness" not in doc["contacts"][i]:
                pieces += _contact_pieces(asm, c, {"t": d["h"] / 2}, text, refuse)  # (thickness h/2)
        if d["b"] or d["h"]:
            masses[name] = mass_direction(m, d)
    return pieces, ((lambda: _beam_mass_derivative(asm, masses)) if masses else None)


def _beam_mass_derivative(asm: Assembly, directions: dict) -> sp.csc_matrix:
    """d M / dp of beam3d members whose mass parameters (L, b, h, rho) change by directions[name] per unit p (the
    mass kernel's direction companion: its b x h enter the section's moments nonlinearly)."""
    return _element_matrices(asm, list(directions), lambda name, p: kernels.mass_matrix_direction(
        "beam3d", p, directions[name]))


class _MeshView:
    """The mesh with other loads, gravity and point masses in its scene: loads.load_vector and point_mass_triplets
    (the one home of dead point forces and point masses) evaluated on the derivative's unit values."""

    def __init__(self, mesh, loads=(), gravity=None, point_masses=()):
        self.members, self.n = mesh.members, mesh.n
        dim = mesh.scene.dim
        self.scene = type("SceneView", (), {"loads": list(loads), "point_masses": list(point_masses), "dim": dim,
                                            "gravity": np.zeros(dim) if gravity is None else gravity})()


def read_document(doc: dict | str | Path) -> dict:
    """A scene document: a dict as given, or a TOML file parsed."""
    if isinstance(doc, dict):
        return doc
    return tomllib.loads(Path(doc).read_text())


def check_model_paths(scene: Scene, doc: dict, paths: list[str]) -> None:
    """Refuse, before any solving, a path that names no differentiable number of this scene (KeyError / ValueError
    naming it)."""
    from ancf_sym.statics.problem import problem_for
    for p in paths:
        get_parameter(doc, p)
    asm = problem_for(scene).asm
    for p in paths:
        model_derivative(asm, doc, p)
