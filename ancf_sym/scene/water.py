"""What a scene says about its water: density, surface and depth, seabed, current, waves, and the hydrodynamic
coefficients of each wet member. Every value is checked where it is given; errors name the field."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ancf_sym.util.checks import check_keys, fail, number, vector

WATER_KEYS = ("density", "depth", "surface", "current", "waves", "seabed", "lines", "gauss")
LINE_KEYS = ("cd", "cd_axial", "ca", "ca_axial", "diameter", "buoyancy")
SEABED_KEYS = ("stiffness", "damping", "mu", "eps", "thickness")
WAVE_KEYS = ("height", "period", "direction", "phase", "stretching")
STRETCHING = ("wheeler", "none")
GAUSS = (3, 5, 7)


@dataclass(frozen=True)
class LineCoefficients:
    """Morison coefficients of one member (MoorDyn's convention): cd normal drag on the diameter, cd_axial
    tangential drag on the circumference pi d, ca and ca_axial added-mass coefficients on the displaced area,
    diameter [m] (None: the volume-equivalent diameter of the section's area), buoyancy (False: a dry member)."""
    cd: float = 0.0
    cd_axial: float = 0.0
    ca: float = 0.0
    ca_axial: float = 0.0
    diameter: float | None = None
    buoyancy: bool = True


@dataclass(frozen=True)
class Seabed:
    """The flat seabed at the water's depth: the existing ground contact (ancf_sym.contact) of every wet member,
    stiffness [N/m^2 per unit length], damping [N s/m^2], Coulomb friction mu with regularisation eps [m/s], and the
    centre line's height above the bottom where it rests (thickness [m], 0: MoorDyn's convention)."""
    stiffness: float
    damping: float = 0.0
    mu: float = 0.0
    eps: float = 1e-3
    thickness: float = 0.0


@dataclass(frozen=True)
class Current:
    """Horizontal current [m/s]: uniform (one vector) or by height (piecewise linear between (z, vector) points,
    constant beyond the first and last)."""
    z: np.ndarray  # (k,) heights [m], increasing (one entry: uniform)
    u: np.ndarray  # (k, dim) velocities [m/s]


@dataclass(frozen=True)
class Waves:
    """Regular Airy waves of finite depth: height H = 2 a [m], period T [s], direction [deg] of travel in the
    horizontal plane (from x toward y; 2D: 0 or 180), phase [rad], and how the kinematics reach the moving surface
    (stretching: "wheeler", MoorDyn's convention, or "none": linear theory at the point's own depth; either way a
    point above the surface takes the surface's kinematics, ancf_sym.model.waves)."""
    height: float
    period: float
    direction: float = 0.0
    phase: float = 0.0
    stretching: str = "wheeler"


@dataclass
class Water:
    density: float  # [kg/m^3]
    depth: float  # [m] from the surface to the seabed (math.inf: no seabed)
    surface: float = 0.0  # height of the still water line [m] (vertical: y in 2D, z in 3D)
    current: Current | None = None
    waves: Waves | None = None
    seabed: Seabed | None = None
    lines: dict = field(default_factory=dict)  # member name -> LineCoefficients (every member is wet)
    gauss: int = 5  # points per element of the Morison and water-line terms

    @property
    def bottom(self) -> float:
        return self.surface - self.depth

    def coefficients(self, member: str) -> LineCoefficients:
        return self.lines.get(member, LineCoefficients())


def _coefficients(path: str, d: Any) -> LineCoefficients:
    if isinstance(d, LineCoefficients):
        return d
    if not isinstance(d, dict):
        raise fail(path, "must be a table of cd, cd_axial, ca, ca_axial, diameter, buoyancy", d)
    check_keys(path, d, LINE_KEYS)
    kw = {k: number(f"{path}.{k}", d[k], nonneg=True) for k in ("cd", "cd_axial", "ca", "ca_axial") if k in d}
    if d.get("diameter") is not None:
        kw["diameter"] = number(f"{path}.diameter", d["diameter"], positive=True)
    if "buoyancy" in d:
        if not isinstance(d["buoyancy"], bool):
            raise fail(f"{path}.buoyancy", "must be true or false", d["buoyancy"])
        kw["buoyancy"] = d["buoyancy"]
    return LineCoefficients(**kw)


def _current(path: str, c: Any, dim: int) -> Current | None:
    """A vector (uniform) or a list of [z, vector] points, z increasing."""
    if c is None:
        return None
    if isinstance(c, (list, tuple, np.ndarray)) and len(c) and not isinstance(c[0], (list, tuple, np.ndarray)):
        u = vector(path, c, dim)
        zs, us = np.zeros(1), u[None, :]
    else:
        if not isinstance(c, (list, tuple)) or not c:
            raise fail(path, f"must be a velocity ({dim} numbers) or a list of [z, velocity] points", c)
        zs, us = [], []
        for i, p in enumerate(c):
            if not isinstance(p, (list, tuple)) or len(p) != 2:
                raise fail(f"{path}[{i}]", "must be [z, velocity]", p)
            zs.append(number(f"{path}[{i}][0]", p[0]))
            us.append(vector(f"{path}[{i}][1]", p[1], dim))
        zs, us = np.array(zs), np.array(us)
        if np.any(np.diff(zs) <= 0):
            raise fail(path, "heights z must increase from point to point", zs.tolist())
    if np.any(us[:, -1] != 0):
        raise fail(path, "the current is horizontal: its vertical component must be 0", us.tolist())
    return Current(zs, us)


def _waves(path: str, w: Any, dim: int) -> Waves | None:
    if w is None or isinstance(w, Waves):
        return w
    if not isinstance(w, dict):
        raise fail(path, "must be a table of height, period, direction, phase, stretching", w)
    check_keys(path, w, WAVE_KEYS, required=("height", "period"))
    st = w.get("stretching", "wheeler")
    if st not in STRETCHING:
        raise fail(f"{path}.stretching", f"must be one of {STRETCHING}", st)
    out = Waves(number(f"{path}.height", w["height"], positive=True),
                number(f"{path}.period", w["period"], positive=True),
                number(f"{path}.direction", w.get("direction", 0.0)), number(f"{path}.phase", w.get("phase", 0.0)),
                st)
    if dim == 2 and out.direction % 180.0 != 0.0:
        raise fail(f"{path}.direction", "in a planar scene waves travel along x: 0 or 180", out.direction)
    return out


def _seabed(path: str, s: Any) -> Seabed | None:
    if s is None or isinstance(s, Seabed):
        return s
    if not isinstance(s, dict):
        raise fail(path, "must be a table of stiffness, damping, mu, eps, thickness", s)
    check_keys(path, s, SEABED_KEYS, required=("stiffness",))
    kw = {k: number(f"{path}.{k}", s[k], nonneg=True) for k in SEABED_KEYS if k in s}
    if kw["stiffness"] <= 0:
        raise fail(f"{path}.stiffness", "must be > 0 (the seabed's penalty stiffness, N/m^2)", s["stiffness"])
    if kw.get("mu", 0.0) > 0 and kw.get("eps", 1e-3) <= 0:
        raise fail(f"{path}.eps", "must be > 0 with friction (regularisation velocity, m/s)", s.get("eps"))
    return Seabed(**kw)


def set_water(scene, density: float = 1025.0, depth: float = math.inf, surface: float = 0.0,
              current: Any = None, waves: Any = None, seabed: Any = None,
              lines: dict | None = None, gauss: int = 5) -> Water:
    """Put the scene's members in water (see Scene.set_water). Checks every value, adds the seabed contacts."""
    if getattr(scene, "water", None) is not None:
        raise fail("water", "is already set for this scene", scene.water)
    rho = number("water.density", density, positive=True)
    h = math.inf if depth is None or depth == math.inf else number("water.depth", depth, positive=True)
    zs = number("water.surface", surface)
    if isinstance(gauss, bool) or gauss not in GAUSS:
        raise fail("water.gauss", f"must be one of {GAUSS}", gauss)
    lines = {} if lines is None else lines
    if not isinstance(lines, dict):
        raise fail("water.lines", "must be a table: member name -> coefficients", lines)
    coef = {}
    for name, d in lines.items():
        if name not in scene.members:
            raise fail(f"water.lines.{name}", f"is not a member; members: {sorted(scene.members)}", name)
        coef[name] = _coefficients(f"water.lines.{name}", d)
    for name, m in scene.members.items():
        if m.element == "beam3d":
            raise fail("water", f"member {name!r} is a beam3d: water acts on cable members (cable2d, cable3d)",
                       m.element)
    sb = _seabed("water.seabed", seabed)
    if sb is not None and not math.isfinite(h):
        raise fail("water.seabed", "needs a finite water.depth (the seabed lies at surface - depth)", seabed)
    wv = _waves("water.waves", waves, scene.dim)
    if wv is not None and not math.isfinite(h):
        raise fail("water.depth", "Airy waves need a finite depth", depth)
    w = Water(rho, h, zs, _current("water.current", current, scene.dim), wv, sb, coef, int(gauss))
    if sb is not None:
        up = np.zeros(scene.dim)
        up[-1] = 1.0
        for name in scene.members:  # the existing ground contact, at the depth
            scene.contact_ground(name, stiffness=sb.stiffness, normal=up, level=w.bottom, thickness=sb.thickness,
                                 damping=sb.damping, mu=sb.mu, eps=sb.eps if sb.eps > 0 else 1e-3)
    scene.water = w
    return w


def displaced_area(member, coef: LineCoefficients) -> float:
    """The section's displaced area [m^2]: pi d^2 / 4 of a given hydrodynamic diameter, else the section's area."""
    if coef.diameter is not None:
        return math.pi * coef.diameter ** 2 / 4
    return float(member.section.area)


def diameter(member, coef: LineCoefficients) -> float:
    return coef.diameter if coef.diameter is not None else math.sqrt(4 * float(member.section.area) / math.pi)


def net_weight_density(w: "Water | None", member) -> float:
    """rho A - rho_w A_displaced [kg/m]: the mass per length whose weight the gravity term applies to a fully
    submerged member (buoyancy is the weight of the displaced water; the water line term corrects a member that
    leaves the water)."""
    rhoA = member.material.density * member.section.area
    if w is None:
        return rhoA
    c = w.coefficients(member.name)
    return rhoA - (w.density * displaced_area(member, c) if c.buoyancy else 0.0)
