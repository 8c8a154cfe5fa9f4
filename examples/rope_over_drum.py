"""Rope over a drum: statics with exact frictionless contact (unilateral constraints, no stiffness) against the
closed forms of a frictionless wrap.

Wrap. A steel rope (d = 10 mm, E = 200 GPa, EI ~ 0, Biot strain, no gravity) pinned at (-a, -h) and (a, -h),
a = 0.5 m, h = 0.4 m, passes over a fixed drum of radius R = 0.2 m centred at the origin; its unstretched length is
the wrap path's divided by 1.001 (strain 1e-3). Contact is `method="exact"`: the gap |r - c| - R - t >= 0 at the
Gauss points of every element is an inequality constraint of the IPOPT problem (compiled gap kernels, exact
Jacobian and Hessian), and its multiplier is the contact force at the point. IPOPT starts from the rope wrapped
around a circle 30 % larger, unstretched. Frictionless contact cannot change the tension along the rope, so the
centre line follows the shortest path: tangent from the pin to the circle of radius rho = R + t, arc, tangent;
the wrap angle is pi - 2 theta with theta = atan2(-h, a) + acos(rho / sqrt(a^2 + h^2)) (the tangent point's angle),
the tension T = EA (path / L0 - 1) everywhere, the contact line pressure T / rho and the drum's reaction
2 T sin(wrap / 2). Helix (3D, cable3d, cylinder of axis z): the same with the pins at z = -+0.2 m: unrolled, the
cylinder is a plane and the rope a straight line, so it is a helix of slope angle alpha, cos(alpha) = path_xy /
path; pressure T cos^2(alpha) / rho, reaction 2 T cos(alpha) sin(wrap / 2) normal to the axis, none along it.

Pulley. A movable pulley (a planar rigid body of mass m on a vertical prismatic joint) hangs in the bight of a
weightless rope pinned at (-+a, 0): the rope carries the weight, 2 T cos(beta) = m g with beta the spans' angle to
the vertical; the pulley's depth y follows from the rope's length (closed form solved by brentq).

Records per case (wrap2d_n*, helix3d_n*: n = 24, 48, 96, --quick 24; pulley): T_ref_N and the elements' mean
tension on the wrap (T_wrap_min_N, T_wrap_max_N), pin_force_N, reaction_N vs reaction_ref_N, pressure_N_m vs
pressure_ref_N_m, wrap_rad (the turn between the spans) vs wrap_ref_rad, min_gap_m, iterations; pulley: depth_m vs depth_ref_m, pin_force_N vs T_ref_N,
reaction_N vs weight_N. Figure: the relative errors against the number of elements, and the wrapped rope.

Run: python examples/rope_over_drum.py [--quick] [--json out.json] [--out DIR]
"""
from __future__ import annotations

import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common as C  # noqa: E402  (first: it limits BLAS threads before numpy loads)

import numpy as np  # noqa: E402
from scipy.optimize import brentq  # noqa: E402

from ancf_sym import Material, Scene, Section, solve_static  # noqa: E402
from ancf_sym.contact import exact as contact_exact  # noqa: E402
from ancf_sym.model.assembly import Assembly  # noqa: E402
from ancf_sym.elements.quadrature import gauss01  # noqa: E402
from ancf_sym.elements.hermite import weights  # noqa: E402

G = 9.81
D, R, A, H, ZOFF = 0.01, 0.2, 0.5, 0.4, 0.2
STEEL = Material(E=200e9, density=7850.0)
SEC = Section(area=math.pi * D**2 / 4, I=1e-15)  # a rope: bending stiffness negligible (regular tangent only)
EA = STEEL.E * SEC.area
STRAIN = 1e-3
RHO = R + D / 2  # radius of the centre line on the drum


# -- closed form ------------------------------------------------------------------------------------------------
def tangent_path(rho: float, a: float = A, h: float = H) -> tuple[float, float, float, float]:
    """(theta, wrap, l, length) of the path pin (-a, -h) -> tangent -> arc of radius rho over the top -> (a, -h):
    theta the right tangent point's angle, l a tangent's length."""
    d = math.hypot(a, h)
    theta = math.atan2(-h, a) + math.acos(rho / d)
    wrap = math.pi - 2 * theta
    l = math.sqrt(d * d - rho * rho)
    return theta, wrap, l, 2 * l + rho * wrap


def path_point(s: float, rho: float) -> tuple[np.ndarray, np.ndarray]:
    """Point and unit tangent at distance s along the planar tangent-arc-tangent path."""
    theta, wrap, l, _ = tangent_path(rho)
    left_t = rho * np.array([-math.cos(theta), math.sin(theta)])
    if s <= l:
        u = (left_t - (-A, -H)) / l
        return np.array([-A, -H]) + s * u, u
    if s <= l + rho * wrap:
        phi = math.pi - theta - (s - l) / rho
        radial = np.array([math.cos(phi), math.sin(phi)])
        return rho * radial, np.array([radial[1], -radial[0]])
    right_t = rho * np.array([math.cos(theta), math.sin(theta)])
    u = (np.array([A, -H]) - right_t) / l
    return right_t + (s - l - rho * wrap) * u, u


def wrap_reference(dim: int) -> dict:
    _, wrap, _, lxy = tangent_path(RHO)
    dz = 2 * ZOFF if dim == 3 else 0.0
    length = math.hypot(lxy, dz)
    cos_a = lxy / length
    T = EA * STRAIN
    return {"T_ref_N": T, "wrap_ref_rad": wrap, "L0": length / (1 + STRAIN), "cos_alpha": cos_a,
            "pressure_ref_N_m": T * cos_a**2 / RHO, "reaction_ref_N": 2 * T * cos_a * math.sin(wrap / 2)}


# -- helpers on results -------------------------------------------------------------------------------------------
def point_on(asm, x, member: str, element: int, xi: float, slope: bool = False) -> np.ndarray:
    """r (or r_x) at xi of an element of a member."""
    mm = asm.mesh.members[member]
    d = asm.scene.dim
    X = asm.member_coordinates(x, member)
    a, b = mm.elem_nodes[element]
    w = weights(xi, mm.elem_length[element])[1 if slope else 0]
    return w[0] * X[a, :d] + w[1] * X[a, d:2 * d] + w[2] * X[b, :d] + w[3] * X[b, d:2 * d]


def contact_summary(res, centre, axis=None) -> dict:
    """The rope's tension in the elements on the wrap (EA (mean stretch - 1), 5 Gauss points: the mean over an
    element, not the stretch at a point, where the cubic element rounds off the kink a point force makes), the
    contact forces' resultant normal to the axis and their sum, the wrap (the turn between the spans, whose
    directions are those of the pins' forces) and the smallest gap."""
    asm, x = res.assembly, res.x
    pts = contact_exact.points(asm, x, res.constraint_forces["contact"])
    f = np.array([p["force"] for p in pts])
    resultant, angle = np.zeros(asm.scene.dim), []
    for p, fi in zip(pts, f):
        r = point_on(asm, x, p["member"], p["element"], p["xi"]) - centre
        if axis is not None:
            r = r - (r @ axis) * axis
        resultant += fi * r / np.linalg.norm(r)
        angle.append(math.atan2(r[1], r[0]))
    angle = np.unwrap(angle)
    loaded = f > 1e-3 * f.max()
    lo, hi = angle[loaded].min(), angle[loaded].max()
    on_wrap: dict = {}
    for p, phi in zip(pts, angle):  # elements whose points all lie between the outermost loaded points
        on_wrap.setdefault(p["element"], []).append(lo <= phi <= hi)
    xg, wg = gauss01(5)
    tension = [EA * (sum(w * np.linalg.norm(point_on(asm, x, "rope", e, xi, True)) for xi, w in zip(xg, wg)) - 1)
               for e, inside in on_wrap.items() if all(inside)]
    spans = [np.asarray(res.constraint_forces[f"pin rope@{e}"])[:2] for e in ("start", "end")]
    turn = math.acos(np.clip(-spans[0] @ spans[1] / np.linalg.norm(spans[0]) / np.linalg.norm(spans[1]), -1, 1))
    tension = tension or [float("nan")]  # (a coarse mesh touches at single points: no element wholly on the wrap)
    return {"T_wrap_min_N": min(tension), "T_wrap_max_N": max(tension), "elements_on_wrap": len(tension),
            "contact_force_N": float(f.sum()), "reaction_N": float(np.linalg.norm(resultant[:2])),
            "wrap_rad": turn, "min_gap_m": min(p["gap"] for p in pts)}


# -- cases ------------------------------------------------------------------------------------------------------------
def drum_case(n: int, dim: int = 2) -> dict:
    """A rope pinned at (-+a, -h[, -+zoff]) over the drum, n elements; from the rope wrapped 30 % wider."""
    ref = wrap_reference(dim)
    z = (lambda v: [v]) if dim == 3 else (lambda v: [])
    p0, p1 = [-A, -H, *z(-ZOFF)], [A, -H, *z(ZOFF)]
    sc = Scene(dim=dim, gravity=(0.0,) * dim, name=f"rope_over_drum_{dim}d")
    chord = float(np.linalg.norm(np.subtract(p1, p0)))
    sc.member("rope", [p0, p1], n, STEEL, SEC, axial="biot", prestrain=chord / ref["L0"] - 1)
    sc.pin("rope", "start")
    sc.pin("rope", "end")
    sc.contact_drum("rope", (0.0,) * dim, R, method="exact", **({"axis": (0, 0, 1)} if dim == 3 else {}))
    asm = Assembly(sc)
    x0 = asm.x0.copy()
    mm = asm.mesh.members["rope"]
    X = x0[mm.offset:mm.offset + mm.x0.size].reshape(mm.n_nodes, mm.node_size)
    _, _, _, lxy = tangent_path(1.3 * RHO)
    length = math.hypot(lxy, 2 * ZOFF if dim == 3 else 0.0)
    for k, s in enumerate(mm.s_node):  # unstretched, along the wider path
        r, u = path_point(s * lxy / length, 1.3 * RHO)
        if dim == 3:
            r, u = np.r_[r, -ZOFF + 2 * ZOFF * s / length], np.r_[u * lxy / length, 2 * ZOFF / length]
        X[k, :dim], X[k, dim:2 * dim] = r, u
    res = solve_static(asm, warm_start=x0)
    rec = {"case": f"{'wrap2d' if dim == 2 else 'helix3d'}_n{n}", "n": n, "success": res.success,
           "status": res.status, "iterations": res.iterations, "wall_s": res.wall_s, "rho_m": RHO,
           "element_angle_rad": ref["L0"] / n / RHO, **ref}
    if res.success:
        axis = np.array([0.0, 0.0, 1.0]) if dim == 3 else None
        rec.update(contact_summary(res, np.zeros(dim), axis))
        pins = [np.asarray(res.constraint_forces[f"pin rope@{e}"]) for e in ("start", "end")]
        rec["pin_force_N"] = float(np.linalg.norm(pins[0]))
        rec["pressure_N_m"] = rec["contact_force_N"] / (RHO * rec["wrap_ref_rad"] / rec["cos_alpha"])
    return rec, (res.nodes("rope") if res.success else None)


def pulley_case(n: int, mass: float = 2.0, span: float = 1.0, length: float = 1.6) -> dict:
    """A pulley of mass m on a vertical prismatic joint in the bight of a weightless rope of unstretched length
    `length` pinned at (-+span/2, 0); from the pulley 10 % lower than the closed form, the rope unstretched."""
    W, a = mass * G, span / 2
    y_ref, T_ref = pulley_reference(W, a, length)
    y0 = 1.1 * y_ref
    sc = Scene(dim=2, gravity=(0.0, -G), name="rope_pulley")
    sc.member("rope", [(-a, 0.0), (a, 0.0)], n, STEEL, SEC, axial="biot", gravity=False,
              prestrain=span / length - 1)
    sc.pin("rope", "start")
    sc.pin("rope", "end")
    sc.body("pulley", mass, 0.5 * mass * R**2, position=(0.0, -y0))
    sc.prismatic("pulley", axis=(0.0, 1.0))
    sc.contact_drum("rope", radius=R, body="pulley", method="exact")
    asm = Assembly(sc)
    x0 = asm.x0.copy()
    mm = asm.mesh.members["rope"]
    X = x0[mm.offset:mm.offset + mm.x0.size].reshape(mm.n_nodes, mm.node_size)
    stretch = bight(RHO, a, y0)[3] / length
    for k, s in enumerate(mm.s_node):
        X[k, :2], X[k, 2:4] = bight_point(s * stretch, RHO, a, y0)
    res = solve_static(asm, warm_start=x0)
    rec = {"case": "pulley", "n": n, "success": res.success, "status": res.status, "iterations": res.iterations,
           "wall_s": res.wall_s, "depth_ref_m": y_ref, "T_ref_N": T_ref, "weight_N": W}
    if res.success:
        o = asm.mesh.bodies["pulley"]
        centre = res.x[o:o + 2]
        rec.update(contact_summary(res, centre))
        # (the stretch is 1e-6 here: EA (stretch - 1) per element is not a measure of T; the pins' forces are)
        del rec["T_wrap_min_N"], rec["T_wrap_max_N"]
        rec["depth_m"] = float(-centre[1])
        rec["pin_force_N"] = float(np.linalg.norm(res.constraint_forces["pin rope@start"]))
    return rec


def bight(rho: float, a: float, y: float) -> tuple[float, float, float, float]:
    """(psi, wrap, l, length) of the path (-a, 0) -> tangent -> arc under a circle of radius rho centred at (0, -y)
    -> tangent -> (a, 0): psi the right tangent point's angle (the spans lean out by beta = -psi from the
    vertical), wrap = pi + 2 psi, l a tangent's length."""
    d = math.hypot(a, y)
    psi = math.atan2(y, a) - math.acos(rho / d)
    l = math.sqrt(d * d - rho * rho)
    wrap = math.pi + 2 * psi
    return psi, wrap, l, 2 * l + rho * wrap


def bight_point(s: float, rho: float, a: float, y: float) -> tuple[np.ndarray, np.ndarray]:
    psi, wrap, l, _ = bight(rho, a, y)
    c = np.array([0.0, -y])
    if s <= l:
        u = (c + rho * np.array([-math.cos(psi), math.sin(psi)]) - (-a, 0.0)) / l
        return np.array([-a, 0.0]) + s * u, u
    if s <= l + rho * wrap:
        phi = math.pi - psi + (s - l) / rho
        return c + rho * np.array([math.cos(phi), math.sin(phi)]), np.array([-math.sin(phi), math.cos(phi)])
    tr = c + rho * np.array([math.cos(psi), math.sin(psi)])
    u = (np.array([a, 0.0]) - tr) / l
    return tr + (s - l - rho * wrap) * u, u


def pulley_reference(W: float, a: float, length: float) -> tuple[float, float]:
    """(depth y, tension T): 2 T cos(beta) = W and the path is the rope stretched by T / EA."""
    def mismatch(y):
        psi, _, _, path = bight(RHO, a, y)
        return path - length * (1 + W / (2 * math.cos(psi)) / EA)

    y = brentq(mismatch, math.sqrt(max(RHO**2 - a**2, 0.0)) + 1e-6, length, xtol=1e-14)
    return y, W / (2 * math.cos(bight(RHO, a, y)[0]))


def main(argv=None):
    a = C.parser("rope_over_drum", __doc__).parse_args(argv)
    ns = (24,) if a.quick else (24, 48, 96)
    runs = [(dim, n, *drum_case(n, dim)) for dim in (2, 3) for n in ns]
    records = [r for _, _, r, _ in runs] + [pulley_case(24)]
    C.table(records[:-1], ["case", "T_ref_N", "T_wrap_min_N", "T_wrap_max_N", "pin_force_N", "reaction_N",
                           "reaction_ref_N", "pressure_N_m", "pressure_ref_N_m", "wrap_rad", "wrap_ref_rad",
                           "min_gap_m", "iterations", "status"])
    C.table(records[-1:], ["case", "depth_m", "depth_ref_m", "pin_force_N", "T_ref_N", "reaction_N", "weight_N",
                           "iterations", "status"])

    def plots(out):
        plt = C.pyplot()
        fig, ax = plt.subplots(1, 2, figsize=(11, 4.2))
        for dim, marker in ((2, "o-"), (3, "s--")):
            rs = [r for d, _, r, _ in runs if d == dim and r["success"]]
            n = [r["n"] for r in rs]
            for key, ref, c in (("pin_force_N", "T_ref_N", "C0"), ("reaction_N", "reaction_ref_N", "C1"),
                                ("pressure_N_m", "pressure_ref_N_m", "C2")):
                ax[0].loglog(n, [abs(r[key] / r[ref] - 1) for r in rs], marker, color=c,
                             label=f"{key.split('_')[0]} ({dim}D)")
        ax[0].set_xlabel("elements"), ax[0].set_ylabel("relative error vs closed form"), ax[0].legend(fontsize=7)
        ax[0].set_title("tension (pins), drum reaction, line pressure")
        th = np.linspace(0, 2 * np.pi, 200)
        ax[1].fill(R * np.cos(th), R * np.sin(th), color="0.85")
        _, _, _, shape = runs[0]
        ref = np.array([path_point(s, RHO)[0] for s in np.linspace(0, tangent_path(RHO)[3], 300)])
        ax[1].plot(ref[:, 0], ref[:, 1], "-", lw=3, alpha=0.35, label="tangent-arc-tangent (closed form)")
        if shape is not None:
            ax[1].plot(shape[:, 0], shape[:, 1], "o", ms=3, label=f"ANCF, exact contact, n = {runs[0][1]}")
        ax[1].set_aspect("equal"), ax[1].legend(fontsize=7), ax[1].set_title("rope over a frictionless drum")
        C.save(fig, out, "rope_over_drum.png")

    return C.finish(records, a, plots)


if __name__ == "__main__":
    main()
