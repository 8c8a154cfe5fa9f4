"""The water's terms of a scene differentiated with respect to one scene parameter (a TOML path), exactly.

The water acts on the lines through the buoyancy (the gravity kernel's net weight rho A - rho_w A_displaced), the
water line's potential, the Morison drag on the velocity relative to current and waves, the waves' fluid inertia and
the added mass (ancf_sym.model.water_forces). A parameter reaches them through per-point coefficients (hydrodynamic
diameter d, displaced area A, cd, cd_axial, ca, ca_axial), the water's density, the current, the waves' height and
|g|. Here those coefficients are written as c + s dc/dp with a symbolic scalar s, the model's own force graphs are
built on them, and d/dp is d/ds at s = 0 by CasADi's AD: exact (the drag is quadratic in the relative velocity and
smooth there, up to the regularisation of |u| at zero relative speed; linear in cd and rho_w, as the added mass is
in ca and rho_w). The net weight's derivative replaces the gravity kernel's coefficient column (its kernel is
linear in rho A).

Parameters: `water.density`; `water.current[k]` (a uniform current) and `water.current[j][1][k]` (a point of a
current profile: the piecewise-linear profile is linear in its values); `water.lines.NAME.cd | cd_axial | ca |
ca_axial | diameter`; `water.waves.height | period | phase` (the wave number by the dispersion relation differentiated
implicitly); `water.seabed.stiffness` (model_derivative's contact pieces); and the model's own (materials.M.density,
sections.S.area | diameter, scene.gravity[last], a member's prestrain: its wet points' lengths) where they change the
water's terms. Refused by name: the water's depth and surface (they move the seabed and the water line), the seabed's
other numbers, the waves' direction, horizontal gravity components (water needs gravity along the vertical).
"""
from __future__ import annotations

import dataclasses
import math
from typing import Callable

import casadi as ca
import numpy as np
import scipy.sparse as sp

from ancf_sym import kernels
from ancf_sym.model.water_forces import (added_mass_product, current_mx, drag_force, fluid_inertia_force,
                                         gravity_magnitude, point_positions, water_line_energy)
from ancf_sym.model.water_points import wet_points
from ancf_sym.model.waves import kinematics_mx, wave_number
from ancf_sym.scene.water import Current, diameter, displaced_area
from ancf_sym.system import water as system_water
from ancf_sym.util.sparsity import dm

LINE_PARAMETERS = ("cd", "cd_axial", "ca", "ca_axial", "diameter")


@dataclasses.dataclass
class _Points:
    """WetPoints with coefficients that may be CasADi expressions of s (the numeric flags from the values)."""
    dim: int
    B: sp.csr_matrix
    Bx: sp.csr_matrix
    wL: np.ndarray
    d: object
    area: object
    cd: object
    cd_axial: object
    ca: object
    ca_axial: object
    inertia_area: object
    P: int
    buoyant: bool
    drag: bool
    added_mass: bool


@dataclasses.dataclass
class WaterTangent:
    """d/dp of the water's numbers: per point (dd, darea, dcd, dcda, dca, dcaa), the density, |g|, the waves'
    height, the current (its derivative as a Current of unit values, or None) and per member d(net weight
    density)/dp [kg/m] (the gravity kernel's rhoA column)."""
    drho: float = 0.0
    dg: float = 0.0
    dheight: float = 0.0
    dperiod: float = 0.0
    dphase: float = 0.0
    current: Current | None = None
    point: dict = dataclasses.field(default_factory=dict)  # name -> (P,) array
    dnet: dict = dataclasses.field(default_factory=dict)  # member -> float
    dB: sp.csr_matrix | None = None  # a prestrain: the point maps' derivatives (the elements' lengths move)
    dBx: sp.csr_matrix | None = None

    def moves_water_terms(self) -> bool:
        return bool(self.drho or self.dg or self.dheight or self.dperiod or self.dphase or self.current is not None or
                    self.dB is not None or
                    any(np.any(v) for v in self.point.values()))


def _member_points(asm, water) -> dict:
    """member -> slice of its wet points (wet_points' order: members in mesh order, elements, Gauss points)."""
    out, p0 = {}, 0
    for name, mm in asm.mesh.members.items():
        k = len(mm.elem_length) * water.gauss
        out[name] = slice(p0, p0 + k)
        p0 += k
    return out


def water_tangent(asm, doc: dict, keys: tuple, value: float, refuse: Callable) -> WaterTangent:
    """The tangent of the water's numbers for the parameter at path keys (value: its value); refuse(why) raises."""
    scene, water = asm.scene, asm.scene.water
    wp = wet_points(asm, water)
    slices = _member_points(asm, water)
    tan = WaterTangent()
    P = wp.P

    def point(name: str, member: str, v: float) -> None:
        a = tan.point.setdefault(name, np.zeros(P))
        a[slices[member]] += v

    def members_of(key: str, name: str) -> list:
        return [d["name"] for kind in ("members", "loops") for d in doc.get(kind, []) if d.get(key) == name]

    def section_change(member: str, dA: float) -> None:
        """The section's area changes by dA: weight and, where no hydrodynamic diameter is given, d and A."""
        m, c = scene.members[member], water.coefficients(member)
        follows = c.diameter is None
        if follows:
            d = diameter(m, c)
            point("dd", member, dA * 2.0 / (math.pi * d))  # d = sqrt(4 A / pi)
            if c.buoyancy:
                point("darea", member, dA)
        tan.dnet[member] = (m.material.density - (water.density if (c.buoyancy and follows) else 0.0)) * dA

    if keys[0] == "water":
        rest = keys[1:]
        if rest == ("density",):
            tan.drho = 1.0
            for name, mm in asm.mesh.members.items():
                c = water.coefficients(name)
                tan.dnet[name] = -(displaced_area(mm.member, c) if c.buoyancy else 0.0)
        elif rest[:1] == ("current",):
            c = water.current
            u = np.zeros_like(c.u)
            if len(rest) == 2 and len(c.z) == 1 and np.ndim(doc["water"]["current"][0]) == 0:
                u[0, rest[1]] = 1.0  # (a uniform current: one vector)
            elif len(rest) == 4 and rest[2] == 1:
                u[rest[1], rest[3]] = 1.0  # (a profile point [z, velocity]: its velocity's component)
            else:
                refuse("differentiable current values: water.current[k] of a uniform current, "
                       "water.current[j][1][k] of a profile point (not its height z)")
            if rest[-1] == scene.dim - 1:
                refuse("the current is horizontal: its vertical component is not a parameter")
            tan.current = Current(c.z, u)
        elif len(rest) == 3 and rest[0] == "lines" and rest[2] in LINE_PARAMETERS:
            name, key = rest[1], rest[2]
            if key == "diameter":
                m, c = scene.members[name], water.coefficients(name)
                point("dd", name, 1.0)
                if c.buoyancy:
                    point("darea", name, math.pi * c.diameter / 2)
                    tan.dnet[name] = -water.density * math.pi * c.diameter / 2
            else:
                point({"cd": "dcd", "cd_axial": "dcda", "ca": "dca", "ca_axial": "dcaa"}[key], name, 1.0)
        elif rest == ("waves", "height"):
            tan.dheight = 1.0
        elif rest == ("waves", "period"):
            tan.dperiod = 1.0
        elif rest == ("waves", "phase"):
            tan.dphase = 1.0
        elif rest == ("seabed", "stiffness"):
            pass  # (the seabed's contact kernels: model_derivative's pieces)
        else:
            refuse("differentiable water numbers: water.density, water.current[k] (or a profile point's "
                   "velocity water.current[j][1][k]), water.lines.NAME.cd | cd_axial | ca | ca_axial | diameter, "
                   "water.waves.height | period | phase, water.seabed.stiffness (not the depth, surface, the seabed's "
                   "other numbers, or the waves' direction)")
        return tan
    if keys[0] == "materials" and len(keys) == 3 and keys[2] == "density":
        for name in members_of("material", keys[1]):
            tan.dnet[name] = float(scene.members[name].section.area)
    elif keys[0] == "sections" and len(keys) == 3:
        shape = doc["sections"][keys[1]].get("shape")
        for name in members_of("section", keys[1]):
            if shape is None and keys[2] == "area":
                section_change(name, 1.0)
            elif shape == "circle" and keys[2] == "diameter":
                section_change(name, math.pi * value / 2)
    elif keys[0] in ("members", "loops") and len(keys) == 3 and keys[2] == "prestrain":
        _prestrain(asm, wp, slices, doc[keys[0]][keys[1]]["name"], value, tan)
    elif keys[:2] == ("scene", "gravity") and len(keys) == 3:
        if keys[2] != scene.dim - 1:
            refuse("in water gravity points down the vertical axis: only its last component is a parameter")
        tan.dg = -1.0  # (|g| = -g_vertical; under waves it also sets the wave number)
    return tan


def _prestrain(asm, wp, slices: dict, name: str, eps: float, tan: WaterTangent) -> None:
    """A member's prestrain: its elements' reference length L = l / (1 + eps), dL/deps = -L / (1 + eps). At a point
    r = sum h_i(xi) r_i + L sum h_j(xi) t_j and r_x = sum h_i'(xi) r_i / L + sum h_j'(xi) t_j (positions r_i, slopes
    t_j), with weight w L: d/deps multiplies the slopes' columns of B, the positions' columns of Bx and the weights
    by -1, +1 and -1 over (1 + eps)."""
    mm = asm.mesh.members[name]
    dim, P = wp.dim, wp.P
    idx = mm.elem_dofs()
    slope = np.zeros(asm.n, bool)
    slope[idx[:, dim:2 * dim].ravel()] = True
    slope[idx[:, 3 * dim:4 * dim].ravel()] = True
    rows = np.zeros(dim * P, bool)
    for k in range(dim):
        rows[k * P + np.arange(P)[slices[name]]] = True
    f = 1.0 / (1.0 + eps)

    def part(A: sp.csr_matrix, cols: np.ndarray, c: float) -> sp.csr_matrix:
        A = A.tocoo()
        keep = rows[A.row] & cols[A.col]
        return sp.csr_matrix((c * A.data[keep], (A.row[keep], A.col[keep])), shape=A.shape)
    tan.dB, tan.dBx = part(wp.B, slope, -f), part(wp.Bx, ~slope, f)
    d = tan.point.setdefault("dwL", np.zeros(P))
    d[slices[name]] = -f * wp.wL[slices[name]]


class WaterTerms:
    """d/dp of the water's forces, water line and added mass of a scene for one parameter's tangent (graphs built on
    first use): statics' residual, the dynamics' forcing over a run's states, the added mass's derivative, and the
    forms a frequency's derivative needs."""

    def __init__(self, asm, tan: WaterTangent):
        self.asm, self.tan = asm, tan
        self.water = asm.scene.water
        self.wp = wet_points(asm, self.water)
        self.g = gravity_magnitude(asm.scene)
        self._f: dict = {}

    def _symbolic(self, s: ca.MX) -> tuple:
        """(points, water, |g|) with the coefficients c + s dc."""
        wp, tan, w = self.wp, self.tan, self.water

        def v(name: str, base):
            d = tan.point.get(name)
            return base if d is None or not np.any(d) else ca.DM(base) + s * ca.DM(d)
        d, area = v("dd", wp.d), v("darea", wp.area)
        mask = (wp.area > 0).astype(float)
        inertia = ca.DM(mask) * area + ca.DM(1 - mask) * (np.pi / 4) * d * d if isinstance(d, ca.MX) or \
            isinstance(area, ca.MX) else wp.inertia_area
        B, Bx = wp.B, wp.Bx
        if tan.dB is not None:  # (a prestrain: the point maps move with the elements' lengths)
            B, Bx = dm(wp.B) + s * dm(tan.dB), dm(wp.Bx) + s * dm(tan.dBx)
        pts = _Points(wp.dim, B, Bx, v("dwL", wp.wL), d, area, v("dcd", wp.cd), v("dcda", wp.cd_axial),
                      v("dca", wp.ca), v("dcaa", wp.ca_axial), inertia, wp.P, wp.buoyant,
                      wp.drag or bool(np.any(tan.point.get("dcd", 0))) or bool(np.any(tan.point.get("dcda", 0))),
                      wp.added_mass or bool(np.any(tan.point.get("dca", 0))) or
                      bool(np.any(tan.point.get("dcaa", 0))))
        wat = dataclasses.replace(w, density=w.density + s * tan.drho if tan.drho else w.density)
        if w.waves is not None and (tan.dheight or tan.dperiod or tan.dphase):
            wv = w.waves
            wat.waves = dataclasses.replace(wv, height=wv.height + s * tan.dheight, period=wv.period + s * tan.dperiod,
                                            phase=wv.phase + s * tan.dphase)
        return pts, wat, self.g + s * tan.dg if tan.dg else self.g

    def _wave_number(self, s: ca.MX):
        """k + s dk/dp: the dispersion relation omega^2 = g k tanh(k h) differentiated (implicitly) in omega =
        2 pi / T and g; None where neither moves."""
        tan, w = self.tan, self.water
        if not (tan.dperiod or tan.dg):
            return None
        om, h, g = 2 * math.pi / w.waves.period, w.depth, self.g
        k = wave_number(om, h, g)
        th = math.tanh(k * h)
        dom = -om / w.waves.period * tan.dperiod
        dk = (2 * om * dom - k * th * tan.dg) / (g * th + g * k * h * (1 - th * th))
        return k + s * dk

    def _flow(self, pts, X: ca.MX, s: ca.MX, flow: list | None) -> list | None:
        """The waves' velocity plus s times the current's derivative at the points."""
        if self.tan.current is None:
            return flow
        z = point_positions(pts, X)[-1]
        du = current_mx(dataclasses.replace(self.water, current=self.tan.current), z, pts.dim, s)
        return du if flow is None else [a + b for a, b in zip(flow, du)]

    def _residual_mx(self, X: ca.MX, V: ca.MX | None, t: ca.MX | None, s: ca.MX) -> tuple:
        """(U_waterline, r) with r = grad U_waterline - Q_drag - Q_fluid inertia (full coordinates): statics (V and t
        None: the current's drag on the line at rest, as ancf_sym.statics.water) or the step's (V, t: waves)."""
        pts, wat, g = self._symbolic(s)
        Ub = water_line_energy(pts, wat, g, X)
        r = ca.gradient(Ub, X) if Ub is not None else ca.MX.zeros(X.shape[0])
        Ub = Ub if Ub is not None else ca.MX(0)
        flow = acc = None
        if t is not None and wat.waves is not None:
            _, flow, acc = kinematics_mx(wat, self.g, point_positions(pts, X), t, self._wave_number(s))
        flow = self._flow(pts, X, s, flow)
        statics = V is None
        if pts.drag and (not statics or self.water.current is not None):
            r = r - drag_force(pts, wat, X, V, flow=flow)
        if acc is not None and (pts.buoyant or pts.added_mass):
            r = r - fluid_inertia_force(pts, wat, X, acc)
        return Ub, r

    def _function(self, key: str) -> ca.Function:
        if key in self._f:
            return self._f[key]
        n = self.asm.n
        X, V, t, s = ca.MX.sym("X", n), ca.MX.sym("V", n), ca.MX.sym("t"), ca.MX.sym("s")
        u, w = ca.MX.sym("u", n), ca.MX.sym("w", n)
        if key == "static":  # (dU/dp, dr/dp) at x
            Ub, r = self._residual_mx(X, None, None, s)
            f = ca.Function(key, [X, s], [ca.jacobian(Ub, s), ca.jacobian(r, s)])
        elif key == "dynamic":
            _, r = self._residual_mx(X, V, t, s)
            f = ca.Function(key, [X, V, t, s], [ca.jacobian(r, s)])
        elif key == "forms":  # (dJ/dp) u, w' (dJ/dp) u, w' (D J[dx]) u, (D J[dx]) u; J: the statics' Jacobian
            _, r = self._residual_mx(X, None, None, s)
            Ju = ca.jtimes(r, X, u)
            dx = ca.MX.sym("dx", n)
            q = ca.dot(w, Ju)
            f = ca.Function(key, [X, u, w, dx, s], [ca.jacobian(Ju, s), ca.jacobian(q, s), ca.jtimes(q, X, dx),
                                                     ca.jtimes(Ju, X, dx)])
        elif key == "mass":  # dM_a/dp, u' (dM_a/dp) w, u' (D M_a[dx]) w, (dM_a/dp) w, (D M_a[dx]) w
            pts, wat, _ = self._symbolic(s)
            Mw = added_mass_product(pts, wat, X, w)
            dx = ca.MX.sym("dx", n)
            q = ca.dot(u, Mw)
            f = ca.Function(key, [X, u, w, dx, s], [ca.jacobian(ca.jacobian(Mw, s), w), ca.jacobian(q, s),
                                                     ca.jtimes(q, X, dx), ca.jacobian(Mw, s), ca.jtimes(Mw, X, dx)])
        else:
            raise KeyError(key)
        self._f[key] = f
        return f

    # -- statics ---------------------------------------------------------------------------------------------------
    def residual(self, x: np.ndarray) -> tuple[float, np.ndarray]:
        """(d U_waterline/dp, d r/dp) at x: the statics in water's residual's partial derivative (its water part)."""
        if not self.tan.moves_water_terms():
            return 0.0, np.zeros(len(x))
        dU, dr = self._function("static")(x, 0.0)
        return float(dU), np.asarray(dr).ravel()

    def hessian_vector(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """(d J/dp) u: the water part of the statics' Jacobian differentiated at fixed x."""
        if not self.tan.moves_water_terms():
            return np.zeros(len(x))
        return np.asarray(self._function("forms")(x, u, u, np.zeros(len(x)), 0.0)[0]).ravel()

    def hessian_form(self, x: np.ndarray, u: np.ndarray, w: np.ndarray) -> float:
        if not self.tan.moves_water_terms():
            return 0.0
        return float(self._function("forms")(x, u, w, np.zeros(len(x)), 0.0)[1])

    def third_form(self, x: np.ndarray, dx: np.ndarray, u: np.ndarray, w: np.ndarray | None = None) -> float:
        """w' (D J[dx]) u (w = u by default): the water part of the Jacobian changing with the state along dx."""
        return float(self._function("forms")(x, u, u if w is None else w, dx, 0.0)[2])

    def third_vector(self, x: np.ndarray, dx: np.ndarray, u: np.ndarray) -> np.ndarray:
        """(D J[dx]) u: the water part of the Jacobian's change along dx, times u (full coordinates)."""
        return np.asarray(self._function("forms")(x, u, u, dx, 0.0)[3]).ravel()

    # -- the added mass -------------------------------------------------------------------------------------------
    def mass(self, x: np.ndarray) -> sp.csc_matrix | None:
        """d M_added/dp with the tangents of state x (None: the added mass does not depend on p)."""
        if not self.added_mass_moves():
            return None
        z = np.zeros(self.asm.n)
        return sp.csc_matrix(self._function("mass")(x, z, z, z, 0.0)[0].sparse())  # (linear in w: any w)

    def added_mass_moves(self) -> bool:
        tan, wp = self.tan, self.wp
        if not (wp.added_mass or np.any(tan.point.get("dca", 0)) or np.any(tan.point.get("dcaa", 0))):
            return False
        return bool(tan.drho or tan.dB is not None or
                    any(np.any(tan.point.get(k, 0)) for k in ("dd", "darea", "dca", "dcaa", "dwL")))

    def mass_form(self, x: np.ndarray, u: np.ndarray, dx: np.ndarray, w: np.ndarray | None = None
                  ) -> tuple[float, float]:
        """(w' (dM_a/dp)(x) u, w' (dM_a/dx [dx]) u) (w = u by default): the added mass's derivative at x, its
        change with the state."""
        wp = self.wp
        if not (wp.added_mass or self.added_mass_moves()):
            return 0.0, 0.0
        _, a, b, _, _ = self._function("mass")(x, u if w is None else w, u, dx, 0.0)
        return float(a), float(b)

    def mass_vectors(self, x: np.ndarray, u: np.ndarray, dx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """((dM_a/dp)(x) u, (D M_a[dx]) u) on the full coordinates."""
        z = np.zeros(len(x))
        if not (self.wp.added_mass or self.added_mass_moves()):
            return z, z
        out = self._function("mass")(x, z, u, dx, 0.0)
        return np.asarray(out[3]).ravel(), np.asarray(out[4]).ravel()

    # -- dynamics --------------------------------------------------------------------------------------------------
    def forcing(self, X: np.ndarray, V: np.ndarray | None, t: np.ndarray | None, A: np.ndarray | None = None
                ) -> np.ndarray | None:
        """d r/dp at every state (rows of X, V at times t), full coordinates (len(X), n); V None: the statics'
        (at rest, current only). None: the parameter moves no water force. A: the accelerations, where the
        parameter changes ca and ca_axial differently: the run's inertia is M_a(q_n) a_n (its constant mass matrix
        holds M_a(q_0), ancf_sym.system.water), so its derivative adds (dM_a/dp (q_n) - dM_a/dp (q_0)) a_n to the
        model derivative's dM/dp (q_0) a_n."""
        if not self.tan.moves_water_terms():
            return None
        if V is None:
            return np.array([self.residual(x)[1] for x in X])
        f = self._function("dynamic").map(len(X))
        tt = np.zeros(len(X)) if t is None else np.asarray(t, float)
        out = np.asarray(f(X.T, V.T, tt[None, :], 0.0)).T
        if A is not None and self.added_mass_moves() and \
                np.any(self.tan.point.get("dca", 0) - self.tan.point.get("dcaa", 0)):
            state = getattr(self.asm, "added_mass_state", None)
            x0 = self.asm.x0 if state is None else np.asarray(state, float)
            z = np.zeros((self.asm.n, len(X)))
            m = self._function("mass").map(len(X))
            out += (np.asarray(m(X.T, z, A.T, z, 0.0)[3]) - np.asarray(m(np.repeat(x0[:, None], len(X), 1), z,
                                                                          A.T, z, 0.0)[3])).T
        return out


def gravity_pieces(asm, tan: WaterTangent, piece: Callable) -> list:
    """The gravity kernel's calls with its rhoA column replaced by d(net weight density)/dp per member (the kernel
    is linear in rho A; its gravity columns kept): piece(element, effect, gauss, idx, P, label) builds each."""
    out = []
    for t in asm.terms:
        if t.label != "gravity" or t.effect != "gravity":
            continue
        names = kernels.parameters(t.element, t.effect)
        j = names.index("rhoA")
        P = np.array(t.P, float)
        P[:, j] = 0.0
        first = t.idx[:, 0]
        for name, dnet in tan.dnet.items():
            mm = asm.mesh.members[name]
            if not mm.member.gravity:
                continue
            rows = (first >= mm.offset) & (first < mm.offset + mm.x0.size)
            P[rows, j] = dnet
        if np.any(P[:, j]):
            out.append(piece(t.element, t.effect, t.gauss, t.idx, P, t.label))
    return out


def water_line_gradient(asm, x: np.ndarray) -> np.ndarray | None:
    """grad U_waterline at x (full coordinates), None where no member displaces water: the part of a result's
    gravity energy that the gravity kernels do not hold."""
    water = asm.scene.water
    wp = wet_points(asm, water)
    X = ca.MX.sym("X", asm.n)
    Ub = water_line_energy(wp, water, gravity_magnitude(asm.scene), X)
    if Ub is None:
        return None
    return np.asarray(ca.Function("g", [X], [ca.gradient(Ub, X)])(x)).ravel()


def water_terms(asm) -> WaterTerms | None:
    """The water's terms of a scene with no parameter tangent (their state derivatives: a frequency's derivative
    follows the water line's Jacobian and the turning added mass along the equilibrium's change); None: dry."""
    if getattr(asm.scene, "water", None) is None:
        return None
    return WaterTerms(asm, WaterTangent())


def unsymmetric(asm) -> bool:
    """Is the linear model about an equilibrium in water unsymmetric (a current's drag: its load stiffness)?"""
    water = getattr(asm.scene, "water", None)
    return bool(water is not None and water.current is not None and wet_points(asm, water).drag)


def water_refusals(S, opts) -> list[str]:
    """What of lines in water the dynamic derivatives do not follow: an added mass that turns with the line
    (ca != ca_axial: the run's mass then depends on the state), a static start under waves (the statics have none)."""
    why = []
    if system_water.nonlinear_inertia(S.asm):
        why.append("lines in water whose added mass turns with the line (ca != ca_axial)")
    if system_water.timed(S.asm) and opts.start == "static":
        why.append("a static start under waves")
    return why
