"""Scene description: members (meshed cables/beams), materials, sections, supports, joints, loads, effects.

The Python API reads like the physics:

    s = Scene(dim=2, gravity=(0, -9.81))
    beam = s.member("beam", points=[(0, 0), (3, 0)], elements=6, material=Material(E=20e9, density=7200),
                    section=Section(area=7.854e-5, I=4.909e-10), axial="decoupled", bending=True, gravity=True)
    s.clamp("beam", at="start")
    s.force("beam", at="end", force=(0, -10))

Every value is checked when it is given; errors name the field and the value. Locations `at` are "start",
"end", a node index (int, negative counts from the end) or, for loads, a material coordinate in metres (float).
"""
from __future__ import annotations

import copyreg
import hashlib
import io
import math
import pickle
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from ancf_sym.util import setup_cache
from ancf_sym.util.checks import SceneError, check_fields, fail, number, vector
from ancf_sym.scene.member_effects import AXIAL  # noqa: F401  (public name: ancf_sym.scene.AXIAL)
from ancf_sym.scene.member_effects import AXIAL_STRAINS, BEAM_METHODS, axial_strain, gauss_orders, stiffness_effects
from ancf_sym.scene.schema import MATERIAL, SECTION

ELEMENT_KINDS = ("cable2d", "cable3d", "beam3d")


MAX_COORDINATE = 1e12  # [m] coordinates beyond this overflow squared lengths and energies long before any solve


def _positive(field_name: str, value: Any) -> float:
    return number(field_name, value, positive=True)


_finite = number
_vector = vector


def _coefficient(field_name: str, value: Any) -> float:
    """A damping coefficient: finite and >= 0."""
    v = number(field_name, value)
    if v < 0:
        raise fail(field_name, "must be >= 0", value)
    return v


@dataclass(frozen=True)
class Material:
    """E [Pa], density [kg/m^3]; shear modulus G [Pa] or Poisson ratio (default 0.3) for torsion and beam3d."""
    E: float
    density: float
    G: float | None = None
    poisson: float | None = None

    def __post_init__(self):
        check_fields(self, MATERIAL, "material")
        if self.G is not None and self.poisson is not None:
            raise fail("material", "give G or poisson, not both", {"G": self.G, "poisson": self.poisson})

    @property
    def nu(self) -> float:
        if self.poisson is not None:
            return float(self.poisson)
        if self.G is not None:
            return self.E / (2 * self.G) - 1
        return 0.3

    @property
    def shear_modulus(self) -> float:
        return self.G if self.G is not None else self.E / (2 * (1 + self.nu))


@dataclass(frozen=True)
class Section:
    """area [m^2]; second moments Iy, Iz [m^4] (I sets both); polar/torsion constant J [m^4]; b x h for beam3d."""
    area: float
    I: float | None = None
    Iy: float | None = None
    Iz: float | None = None
    J: float | None = None
    b: float | None = None
    h: float | None = None

    def __post_init__(self):
        check_fields(self, SECTION, "section")
        if self.I is not None:
            if self.Iy is None:
                object.__setattr__(self, "Iy", self.I)
            if self.Iz is None:
                object.__setattr__(self, "Iz", self.I)
        elif self.Iy is not None and self.Iz is None:
            object.__setattr__(self, "Iz", self.Iy)
        elif self.Iz is not None and self.Iy is None:
            object.__setattr__(self, "Iy", self.Iz)
        if self.J is None and self.Iy is not None:
            object.__setattr__(self, "J", self.Iy + self.Iz)

    @classmethod
    def circle(cls, diameter: float) -> "Section":
        d = _positive("section.diameter", diameter)
        I = math.pi * d**4 / 64
        return cls(area=math.pi * d**2 / 4, I=I, J=2 * I, b=d * math.sqrt(math.pi) / 2, h=d * math.sqrt(math.pi) / 2)

    @classmethod
    def rectangle(cls, b: float, h: float) -> "Section":
        """b along the section's y axis, h along z; J by the thin-rectangle-corrected formula."""
        b, h = _positive("section.b", b), _positive("section.h", h)
        a, c = max(b, h), min(b, h)
        J = a * c**3 * (1 / 3 - 0.21 * c / a * (1 - c**4 / (12 * a**4)))
        return cls(area=b * h, Iy=b * h**3 / 12, Iz=h * b**3 / 12, J=J, b=b, h=h)

    @property
    def bending_inertia(self) -> float | None:
        return self.Iz if self.Iz is not None else self.Iy


@dataclass
class Member:
    name: str
    points: np.ndarray  # (npts, dim) polyline vertices [m]
    elements: int
    material: Material
    section: Section
    element: str
    axial: str | None = "green"
    bending: bool = True
    torsion: bool = False
    gravity: bool = True
    beam_method: str = "continuum"
    gauss: int | None = None
    y_axis: np.ndarray | None = None  # beam3d section axis y (reference); z = x cross y
    prestrain: float = 0.0  # initial stretch |r_x| - 1: the polyline is the member stretched by 1 + prestrain
    # closed member (Scene.loop, ancf_sym.scene.closed): the points are its nodes, these their unit tangents, the last
    # element ends on the first node; loop_length is the path's length (else None: an open polyline)
    tangents: np.ndarray | None = None
    loop_length: float | None = None
    # open circular arc (Scene.arc): its signed reference curvature 1/R [1/m] (> 0 counter-clockwise); the points
    # are its nodes, tangents their unit tangents, loop_length the arc's length
    arc_curvature: float | None = None

    @property
    def closed(self) -> bool:
        return self.tangents is not None and self.arc_curvature is None

    @property
    def length(self) -> float:
        """Unstretched (reference) length [m]: material coordinates run over [0, length]."""
        if self.tangents is not None:
            return self.loop_length / (1.0 + self.prestrain)
        return float(np.sum(np.linalg.norm(np.diff(self.points, axis=0), axis=1))) / (1.0 + self.prestrain)

    @property
    def n_nodes(self) -> int:
        return self.elements + (0 if self.closed else 1)


@dataclass
class Support:
    kind: str  # "clamp" | "pin" | "slope"
    member: str
    at: Any
    method: str = "exact"  # "exact" (equality constraints) | "penalty"
    penalty: Any = None  # factor on EA/(1 m) for positions and EI/(1 m) for slopes (paper 002), default 1;
    # or (position factor, slope factor)


@dataclass
class Joint:
    kind: str  # "hinge" | "rigid"
    a: tuple[str, Any]
    b: tuple[str, Any]
    method: str = "exact"
    penalty: float | None = None
    axis: np.ndarray | None = None  # a hinge of beam3d members: the relative rotation left free (unit, world)


@dataclass
class Load:
    kind: str  # "force" | "distributed" | "moment" | "tension"
    member: str
    at: Any = None
    value: Any = None


@dataclass
class PointMass:
    """A lumped mass [kg] at a member point (node or material coordinate): its mass enters the mass matrix through
    the interpolation weights of that point (m S^T S), its weight m g acts there as a dead force."""
    member: str
    at: Any
    mass: float


@dataclass
class Damping:
    """Dynamics only. kind "rayleigh": C = alpha M + beta K_el, alpha [1/s] on absolute velocities (one value for
    the scene), beta [s] on the elastic tangent stiffness (at the start of each step) of `members` (None: all).
    kind "strain_rate" (cables): dissipation 1/2 int (axial eps_dot^2 + bending |kappa_dot|^2) dx, axial [N s],
    bending [N m^2 s]."""
    kind: str
    alpha: float = 0.0
    beta: float = 0.0
    members: list | None = None
    axial: float = 0.0
    bending: float = 0.0


@dataclass
class Scene:
    dim: int = 2
    gravity: Sequence[float] | None = None
    members: dict[str, Member] = field(default_factory=dict)
    supports: list[Support] = field(default_factory=list)
    joints: list[Joint] = field(default_factory=list)
    loads: list[Load] = field(default_factory=list)
    name: str = "scene"
    dampings: list[Damping] = field(default_factory=list)
    contacts: list = field(default_factory=list)  # ancf_sym.contact declarations
    bodies: dict = field(default_factory=dict)  # rigid bodies by name (bodies.planar.Body in 2D, bodies.spatial in 3D)
    body_joints: list = field(default_factory=list)  # ancf_sym.bodies.planar.BodyJoint
    drives: list = field(default_factory=list)  # ancf_sym.bodies.drives: prescribed angles/positions, applied torques
    point_masses: list = field(default_factory=list)  # PointMass
    water: Any = None  # ancf_sym.water.Water: the members are in water (Scene.set_water)

    def __post_init__(self):
        if isinstance(self.dim, bool) or self.dim not in (2, 3):
            raise fail("scene.dim", "must be 2 or 3", self.dim)
        if not isinstance(self.name, str) or not self.name:
            raise fail("scene.name", "must be a non-empty string", self.name)
        g = self.gravity if self.gravity is not None else [0.0] * self.dim
        self.gravity = vector("scene.gravity", g, self.dim)

    # -- members ---------------------------------------------------------------------------------------------
    def member(self, name: str, points: Sequence[Sequence[float]], elements: int, material: Material,
               section: Section, axial: str | None = "green", bending: bool = True, torsion: bool = False,
               gravity: bool = True, element: str | None = None, beam_method: str | None = None,
               gauss: int | None = None, y_axis: Sequence[float] | None = None, prestrain: float = 0.0) -> Member:
        """Add a straight (2 points) or polyline member meshed into `elements` elements of one kind.

        axial: strain measure "green" | "biot" | "decoupled" (cables) or None ("none") for no axial stiffness
        (ancf_sym.scene.member_effects: what each means).
        element: "cable2d" (default in 2D), "cable3d" (default in 3D) or "beam3d" (beam_method "continuum" (default)
        or "elastic_line"; beam_method and y_axis are refused on cables). Polyline vertices become rigid joints between straight segments.
        prestrain: the points give the member stretched by 1 + prestrain (e.g. a taut string between two pins:
        prestrain = T/EA); its unstretched length is the polyline's divided by 1 + prestrain.
        """
        if not isinstance(name, str) or not name:
            raise fail("members.name", "must be a non-empty string", name)
        at = f"members[{name!r}]"  # errors name the member's field; the TOML reader re-roots this to members[i]
        if name in self.members:
            raise fail(f"{at}.name", "repeats an earlier member's name", name)
        if isinstance(points, (str, bytes)) or not isinstance(points, (list, tuple, np.ndarray)) or len(points) < 2:
            raise fail(f"{at}.points", f"must be a list of >= 2 points with {self.dim} coordinates", points)
        pts = np.array([vector(f"{at}.points[{i}]", p, self.dim) for i, p in enumerate(points)])
        big = np.abs(pts).max()
        if big > MAX_COORDINATE:
            raise fail(f"{at}.points", f"coordinates must lie within +-{MAX_COORDINATE:g} m (lengths and energies "
                       "would overflow); largest", big)
        d = pts[1:] - pts[:-1]
        if np.any((d * d).sum(axis=1) <= 0):  # (a segment's length |d| = 0)
            raise fail(f"{at}.points", "must be distinct (a segment of length 0)", points)
        if isinstance(elements, bool) or not isinstance(elements, (int, np.integer)) or elements < 1:
            raise fail(f"{at}.elements", "must be a positive integer", elements)
        if len(pts) > 2 and elements < len(pts) - 1:
            raise fail(f"{at}.elements", f"must be at least the {len(pts) - 1} segments of the polyline", elements)
        element = element or ("cable2d" if self.dim == 2 else "cable3d")
        if element not in ELEMENT_KINDS:
            raise fail(f"{at}.element", f"must be one of {' | '.join(ELEMENT_KINDS)}", element)
        if (element == "cable2d") != (self.dim == 2):
            raise fail(f"{at}.element", f"does not fit a {self.dim}D scene", element)
        axial = axial_strain(axial, f"{at}.axial")
        for flag, v in (("bending", bending), ("torsion", torsion), ("gravity", gravity)):
            if not isinstance(v, (bool, np.bool_)):
                raise fail(f"{at}.{flag}", "must be true or false", v)
        # keys that only mean something for beam3d are refused elsewhere, not silently ignored
        for key, v in (("beam_method", beam_method), ("y_axis", y_axis), ("torsion", torsion or None)):
            if v is not None and element != "beam3d":  # (a cable has no section orientation)
                raise fail(f"{at}.{key}", f"applies to beam3d members only, not {element}", v)
        beam_method = "continuum" if beam_method is None else beam_method
        if beam_method not in BEAM_METHODS:
            raise fail(f"{at}.beam_method", f"must be one of {' | '.join(BEAM_METHODS)}", beam_method)
        if not isinstance(material, Material):
            raise fail(f"{at}.material", "must be a Material", material)
        if not isinstance(section, Section):
            raise fail(f"{at}.section", "must be a Section", section)
        if axial is not None and AXIAL_STRAINS[axial].needs_bending and not bending:
            # the decoupled energy sees only the nodal stretches and the element's length: without bending stiffness
            # an element can fold at no cost (a hanging soft rope's end element folds into a hook, measured)
            others = " or ".join(repr(k) for k, v in AXIAL_STRAINS.items() if not v.needs_bending)
            raise fail(f"{at}.axial", f"{axial!r} needs bending = true (without bending stiffness the {axial} "
                       f"strain leaves folding modes of an element unresisted); use {others}", axial)
        if element.startswith("cable") and bending and section.bending_inertia is None:
            raise fail(f"{at}.section.I", "is required by bending = true (give I, or Iy/Iz)", None)
        if element == "beam3d":
            if section.b is None or section.h is None:
                raise fail(f"{at}.section.b", "beam3d needs a section with b and h (Section.rectangle)", section.b)
            if beam_method == "elastic_line" and (section.Iy is None or section.J is None):
                raise fail(f"{at}.section.Iy", "elastic_line needs section Iy, Iz and J", section.Iy)
        orders = gauss_orders(element, stiffness_effects(element, axial, bending, torsion, beam_method))
        if gauss is not None and (not isinstance(gauss, (int, np.integer)) or isinstance(gauss, bool)
                                  or gauss not in orders):
            why = "" if len(orders) > 1 else f" (the {beam_method} beam is generated for that order only)"
            raise fail(f"{at}.gauss", f"must be one of {', '.join(map(str, orders))}{why}", gauss)
        ya = None if y_axis is None else vector(f"{at}.y_axis", y_axis, 3)
        pre = number(f"{at}.prestrain", prestrain)
        if not -0.5 < pre < 1.0:
            raise fail(f"{at}.prestrain", "must lie in (-0.5, 1)", prestrain)
        m = Member(name, pts, int(elements), material, section, element, axial, bool(bending), bool(torsion),
                   bool(gravity), beam_method, gauss, ya, pre)
        self.members[name] = m
        return m

    def loop(self, name: str, path: list, elements: int, material: Material, section: Section,
             offset: Sequence[float] | None = None, **options: Any) -> Member:
        """Add a closed member (a belt, a track chain) along `path`, a loop of straight segments and arcs in the
        x-y plane (ancf_sym.scene.closed: pieces, or closed.belt_path(pulleys)), meshed into `elements` elements of equal
        length whose last one ends on the first node; `offset` translates it (3D: e.g. a second track chain in a
        parallel plane). Options as `member` (prestrain: the path is the loop stretched by 1 + prestrain, i.e. its
        unstretched length is the path's / (1 + prestrain))."""
        from ancf_sym.scene import closed

        if isinstance(elements, bool) or not isinstance(elements, (int, np.integer)) or elements < 3:
            raise SceneError(f"loop {name!r}: elements must be an integer >= 3, got {elements!r}")
        pts, tans, total = closed.sample(path, int(elements), self.dim)
        if offset is not None:
            pts = pts + vector(f"loop {name!r}: offset", offset, self.dim)
        m = self.member(name, pts, int(elements), material, section, **options)
        m.tangents, m.loop_length = tans, total
        return m

    def arc(self, name: str, elements: int, material: Material, section: Section, centre: Any = None,
            radius: float | None = None, angle0: float | None = None, sweep: float | None = None,
            through: Any = None, **options: Any) -> Member:
        """Add a curved member: a circular arc in the x-y plane of a 2D scene, stress-free in its reference state.
        Give centre [m], radius [m], angle0 and sweep [rad] (sweep > 0 counter-clockwise, |sweep| < 2 pi), or
        `through` = three points [start, any point between, end]. Its nodes lie on the arc at equal arc length
        with the arc's unit tangents as slopes; the bending energy is that of the curvature change
        1/2 int EI (kappa - kappa0)^2 (kappa0 = +-1/R), up to a constant (docs/scenes.md). Options as `member`."""
        from ancf_sym.scene import closed

        at = f"members[{name!r}]"
        if self.dim != 2:
            raise fail(f"{at}.arc", "curved members (arcs) are planar: a 2D scene's cable2d members", self.dim)
        if isinstance(elements, bool) or not isinstance(elements, (int, np.integer)) or elements < 1:
            raise fail(f"{at}.elements", "must be a positive integer", elements)
        given = {k: v for k, v in (("centre", centre), ("radius", radius), ("angle0", angle0), ("sweep", sweep))
                 if v is not None}
        if (through is None) == (not given):
            raise fail(f"{at}.arc", "give centre, radius, angle0, sweep or through = [start, middle, end], not "
                       "both or neither", {**given, **({"through": through} if through is not None else {})})
        if through is not None:
            if isinstance(through, (str, bytes)) or not isinstance(through, (list, tuple, np.ndarray)) \
                    or len(through) != 3:
                raise fail(f"{at}.arc.through", "must be 3 points [start, a point between, end]", through)
            pts3 = [vector(f"{at}.arc.through[{i}]", p, 2) for i, p in enumerate(through)]
            try:
                c, R, a0, sw = closed.arc_through(*pts3)
            except SceneError as exc:
                raise fail(f"{at}.arc.through", str(exc).split(": ", 1)[-1]) from None
        else:
            for k in ("centre", "radius", "angle0", "sweep"):
                if k not in given:
                    raise fail(f"{at}.arc.{k}", "missing (an arc needs centre, radius, angle0, sweep)")
            c = vector(f"{at}.arc.centre", centre, 2)
            R = number(f"{at}.arc.radius", radius, positive=True)
            a0 = number(f"{at}.arc.angle0", angle0)
            sw = number(f"{at}.arc.sweep", sweep)
            if not 0 < abs(sw) < 2 * math.pi:
                raise fail(f"{at}.arc.sweep", "must be non-zero and less than 2 pi in size (a closed ring is a loop)",
                           sweep)
        if "prestrain" in options:
            raise fail(f"{at}.prestrain", "does not apply to arcs: a curved member is stress-free in its reference "
                       "state", options["prestrain"])
        pts, tans, total = closed.arc_nodes(c, R, a0, sw, int(elements), self.dim)
        m = self.member(name, pts, int(elements), material, section, **options)
        if m.bending and m.axial is None:
            del self.members[name]
            raise fail(f"{at}.axial", "a curved member with bending stiffness needs an axial strain measure", "none")
        m.tangents, m.loop_length, m.arc_curvature = tans, total, math.copysign(1.0 / R, sw)
        if m.bending:  # the stretch at which the arc is an equilibrium of the model (ancf_sym.model.terms, arc_reference)
            a = material.E * section.bending_inertia / (material.E * section.area) / R**2
            lam = (1 + math.sqrt(1 + 4 * a)) / 2 if m.axial == "biot" else math.sqrt((1 + math.sqrt(1 + 8 * a)) / 2)
            m.prestrain = lam - 1.0
        return m

    def set_water(self, **options: Any):
        """Put the members in water (ancf_sym.water.set_water, docs/water.md): density [kg/m^3], depth [m], surface
        (the still water line's height), current (a velocity or [[z, velocity], ...]), waves = {height, period,
        direction, phase, stretching}, seabed = {stiffness, damping, mu, eps, thickness} (ground contacts at the depth),
        lines = {member: {cd, cd_axial, ca, ca_axial, diameter, buoyancy}}, gauss."""
        from ancf_sym.scene.water import set_water

        return set_water(self, **options)

    def contact_ground(self, member: str, **options: Any):
        """Contact of `member`'s centre line with the ground half-space {normal . r >= level} (default: y >= 0 in
        2D, z >= 0 in 3D). Options (ancf_sym.contact.ground): stiffness (linear penalty, N/m^2) and/or hertz
        (k_h delta^1.5 per unit length), thickness (default: a cable's round radius, h/2 of a beam3d section), damping,
        mu and eps (friction regularisation velocity), gauss (contact points per element: 3, 5, 7)."""
        from ancf_sym.contact import laws as contact

        c = contact.ground(self, member, **options)
        self.contacts.append(c)
        return c

    def contact_drum(self, member: str, centre: Any = None, radius: float = 0.0, **options: Any):
        """Contact of `member`'s centre line with a drum it lies outside of: a fixed circle of `centre` and `radius`
        (2D) or a cylinder of unit `axis` (3D, default z); or, with body=NAME instead of a centre, a circle carried
        by that planar rigid body (centred at its centre of mass, turning with it; forces on member and body); in
        3D a cylinder fixed in that spatial body, `centre` (a point on its axis) and `axis` in world coordinates of
        the reference state (defaults: the body's centre and z axis; ancf_sym.contact.body).
        Options as contact_ground (stiffness and/or hertz, thickness, damping, mu, eps, gauss); method 'penalty'
        only (ancf_sym.contact.drum)."""
        from ancf_sym.contact import laws as contact

        c = contact.drum(self, member, centre, radius, **options)
        self.contacts.append(c)
        return c

    # -- rigid bodies (ancf_sym.bodies.planar: planar; ancf_sym.bodies.spatial: 3D scenes) -------------------------------
    def body(self, name: str, mass: float, inertia: Any, position: Sequence[float], angle: float = 0.0,
             force: Sequence[float] | None = None, axes: Any = None):
        """A rigid body with mass [kg], centre of mass `position` [m] in the reference state and a dead `force` [N]
        at its centre; gravity acts on it. Planar (2D scene): `inertia` about the centre [kg m^2] and `angle` [rad]
        of its x axis. Spatial (3D scene): `inertia` as 3 principal moments or a 3x3 tensor about the centre in the
        body axes, `axes` the rows x, y, z of those axes in world components (default the world axes)."""
        if self.dim == 3:
            from ancf_sym.bodies import spatial as spatial_bodies

            if angle not in (0, 0.0):
                raise fail("body.angle", "is planar; a spatial body takes axes (3 rows x, y, z)", angle)
            b = spatial_bodies.make_body(self, name, mass, inertia, position, axes, force)
        else:
            from ancf_sym.bodies import planar as bodies

            if axes is not None:
                raise fail("body.axes", "is for spatial bodies (3D scenes); a planar body takes angle", axes)
            b = bodies.make_body(self, name, mass, inertia, position, angle, force)
        self.bodies[name] = b
        return b

    def revolute(self, body: str, point: Sequence[float] | None = None, axis: Sequence[float] | None = None,
                 other: str | None = None):
        """The body turns about a point (world coordinates in the reference state; default its centre) fixed to the
        ground, or to the body `other` (a wheel on a chassis); in 3D about the world `axis` through it."""
        if self.dim == 2:
            if axis is not None:
                raise fail("revolute.axis", "is for spatial bodies (3D scenes): planar bodies turn about z", axis)
            return self._body_joint("revolute", body, point=point, other=other)
        return self._body_joint("revolute", body, point=point, axis=axis, other=other)

    def spherical(self, body: str, point: Sequence[float] | None = None, other: str | None = None):
        """3D: the body point at `point` (default its centre) stays on the ground point, or on body `other`'s."""
        return self._body_joint("spherical", body, point=point, other=other)

    def prismatic(self, body: str, axis: Sequence[float], point: Sequence[float] | None = None,
                  other: str | None = None):
        """The body slides along the world `axis` (reference state) through `point` (default its centre) without
        turning, relative to the ground or to body `other`."""
        return self._body_joint("prismatic", body, point=point, axis=axis, other=other)

    # -- drives and torques (ancf_sym.bodies.drives) -------------------------------------------------------------------
    def drive(self, body: str, angle: Any = None, omega: Any = None, relative_to: str | None = None,
              angle0: float | None = None, name: str | None = None):
        """Prescribe a body's angle in time (absolute, or relative to the body `relative_to`: a revolute joint's
        angle): `angle` theta(t), or `omega` with angle = angle0 + its integral from the first piece's start
        (angle0 default: the reference angle). A spatial body (3D) turns about the axis of its revolute joint to
        `relative_to` (or to the ground), angle 0 in the reference state, positive about the joint's axis. Motions: a number, a piecewise polynomial [[t_k, [a0, a1, ...]],
        ...] in (t - t_k), or callables (f, df/dt, d2f/dt2) (ancf_sym.bodies.drives)."""
        from ancf_sym.bodies import drives

        d = drives.angle_drive(self, body, angle, omega, relative_to, angle0, name)
        self.drives.append(d)
        return d

    def drive_position(self, position: Sequence[Any], member: str | None = None, at: Any = None,
                       body: str | None = None, name: str | None = None):
        """Prescribe the position of a member node (`member`, `at`; instead of a pin there) or of a body's centre
        in time: one motion per component (as Scene.drive)."""
        from ancf_sym.bodies import drives

        d = drives.position_drive(self, position, member, at, body, name)
        self.drives.append(d)
        return d

    def torque(self, body: str, torque: Any, name: str | None = None):
        """An applied torque on a body [N m, counter-clockwise], constant or a motion of time (as Scene.drive)."""
        from ancf_sym.bodies import drives

        d = drives.torque(self, body, torque, name)
        self.drives.append(d)
        return d

    def pin_body(self, body: str, member: str, at: Any = "end"):
        """A member node tied to the body point where it lies in the reference state (free relative rotation)."""
        return self._body_joint("pin", body, member=member, at=at)

    def rigid_body(self, body: str, member: str, at: Any = "end"):
        """As pin_body, and the member's slope at the node turns with the body (a clamp into the body; beam3d: its
        whole frame of gradients)."""
        return self._body_joint("rigid", body, member=member, at=at)

    def _body_joint(self, kind: str, body: str, **kw: Any):
        if self.dim == 3:
            from ancf_sym.bodies import spatial as spatial_bodies

            j = spatial_bodies.make_joint(self, kind, body, **kw)
        else:
            from ancf_sym.bodies import planar as bodies

            if kind == "spherical":
                raise fail("spherical", "is a joint of spatial bodies (3D scenes); planar bodies have revolute, "
                           "prismatic, pin and rigid", body)
            j = bodies.make_joint(self, kind, body, **kw)
        self.body_joints.append(j)
        return j

    # -- supports and joints -----------------------------------------------------------------------------------
    def _support(self, kind: str, member: str, at: Any, method: str, penalty: float | None) -> Support:
        self.check_at(member, at, node_only=True, field_name=f"{kind}.at")
        self._check_method(kind, method, penalty)
        s = Support(kind, member, at, method, penalty)
        self.supports.append(s)
        return s

    def clamp(self, member: str, at: Any = "start", method: str = "exact", penalty: float | None = None) -> Support:
        """Position and slope direction fixed (beam3d: position and all gradients)."""
        return self._support("clamp", member, at, method, penalty)

    def pin(self, member: str, at: Any = "start", method: str = "exact", penalty: float | None = None) -> Support:
        """Position fixed, slope free."""
        return self._support("pin", member, at, method, penalty)

    def fix_slope(self, member: str, at: Any = "start", method: str = "exact", penalty: float | None = None) -> Support:
        """Slope direction fixed to its reference direction, position free."""
        return self._support("slope", member, at, method, penalty)

    def hinge(self, a: tuple[str, Any], b: tuple[str, Any], method: str = "exact", penalty: float | None = None,
              axis: Sequence[float] | None = None) -> Joint:
        """Shared point, independent slopes. Between beam3d members with `axis` (world, reference state): a revolute
        joint, the node frames turn relative to each other about that axis only; without it every relative rotation
        is free (a ball joint)."""
        if axis is None:
            return self._joint("hinge", a, b, method, penalty)
        if self.dim != 3:
            raise fail("hinge.axis", "is for beam3d members (3D scenes): a planar hinge turns about z", axis)
        ax = vector("hinge.axis", axis, 3)
        if not np.linalg.norm(ax) > 0:
            raise fail("hinge.axis", "must be a nonzero vector", axis)
        for label, end in (("a", a), ("b", b)):
            m = self.members.get(end[0]) if isinstance(end, (tuple, list)) and len(end) == 2 else None
            if m is not None and m.element != "beam3d":
                raise fail("hinge.axis", f"needs beam3d members (a cable carries no section orientation; member "
                           f"{end[0]!r} is {m.element})", axis)
        j = self._joint("hinge", a, b, method, penalty)
        j.axis = ax / np.linalg.norm(ax)
        return j

    def rigid(self, a: tuple[str, Any], b: tuple[str, Any], method: str = "exact", penalty: float | None = None) -> Joint:
        """Shared point and relative slope direction fixed at its reference angle (e.g. a T); beam3d members: the
        relative rotation of the two node frames; a beam3d and a cable3d member: the cable's slope direction in the
        beam's frame."""
        return self._joint("rigid", a, b, method, penalty)

    def _joint(self, kind, a, b, method, penalty) -> Joint:
        for label, end in (("a", a), ("b", b)):
            if not isinstance(end, (tuple, list)) or len(end) != 2:
                raise SceneError(f"{kind}.{label} must be (member, at), got {end!r}")
            self.check_at(end[0], end[1], node_only=True, field_name=f"{kind}.{label}")
        if a[0] == b[0]:
            raise SceneError(f"{kind}: a and b must be different members, got {a!r} and {b!r}")
        if kind == "rigid" and self.members[a[0]].element == self.members[b[0]].element == "cable3d":
            raise SceneError(f"rigid joint between cable3d members {a[0]!r} and {b[0]!r}: a cable carries no section "
                             "orientation (all two slopes could fix is their angle, and the joint would spin freely "
                             "about either); use beam3d members (or one, which holds the cable's slope direction) "
                             "or a planar scene")
        self._check_method(kind, method, penalty)
        j = Joint(kind, tuple(a), tuple(b), method, penalty)
        self.joints.append(j)
        return j

    @staticmethod
    def _check_method(kind, method, penalty):
        """penalty: one factor, or (position factor, slope factor) as paper 002's C1 (x EA/1 m), C2 (x EI/1 m)."""
        if method not in ("exact", "penalty"):
            raise SceneError(f"{kind}.method must be 'exact' or 'penalty', got {method!r}")
        if penalty is None:
            return
        if isinstance(penalty, (list, tuple, np.ndarray)):
            if len(penalty) != 2:
                raise SceneError(f"{kind}.penalty must be a factor or [position factor, slope factor], got {penalty!r}")
            for v in penalty:
                _positive(f"{kind}.penalty", v)
        else:
            _positive(f"{kind}.penalty", penalty)

    # -- loads -------------------------------------------------------------------------------------------------
    def force(self, member: str, at: Any, force: Sequence[float]) -> Load:
        """Dead point force [N] at a node or at a material coordinate s [m] (float)."""
        self.check_at(member, at, node_only=False, field_name="force.at")
        return self._add_load(Load("force", member, at, _vector("force.force", force, self.dim)))

    def distributed(self, member: str, force_per_length: Sequence[float]) -> Load:
        """Dead load [N/m] per unit reference length over the whole member."""
        self._member(member, "distributed.member")
        return self._add_load(Load("distributed", member, None, _vector("distributed.force_per_length",
                                                                        force_per_length, self.dim)))

    def moment(self, member: str, at: Any, moment: Any) -> Load:
        """Moment [N m] at a node: scalar (about z) in 2D; a 3-vector in 3D (beam3d: y and z components)."""
        m = self._member(member, "moment.member")
        self.check_at(member, at, node_only=True, field_name="moment.at")
        if self.dim == 2:
            value = _finite("moment.moment", moment)
        else:
            value = _vector("moment.moment", moment, 3)
            if m.element == "beam3d" and abs(value[0]) > 0:
                raise fail("moment.moment", "beam3d takes moments about the section axes y and z only; x component",
                           value[0])
        return self._add_load(Load("moment", member, at, value))

    def tension(self, member: str, at: Any, tension: float) -> Load:
        """Prescribed tension [N]: a dead force along the member's outward reference axis at that end."""
        self.check_at(member, at, node_only=True, field_name="tension.at")
        return self._add_load(Load("tension", member, at, _finite("tension.tension", tension)))

    def point_mass(self, member: str, at: Any, mass: float) -> PointMass:
        """A point mass [kg] at a node or material coordinate s [m] (float) of a member: added to the mass matrix
        through the interpolation weights at that point; gravity acts on it (a dead force m g at the point)."""
        self.check_at(member, at, node_only=False, field_name="point_mass.at")
        p = PointMass(member, at, _positive("point_mass.mass", mass))
        self.point_masses.append(p)
        return p

    def rayleigh(self, alpha: float = 0.0, beta: float = 0.0, members: Sequence[str] | None = None) -> Damping:
        """Rayleigh damping for dynamics, C = alpha M + beta K_el: alpha [1/s] damps absolute velocities (whole
        scene, one value), beta [s] the elastic tangent stiffness of `members` (default all) at the start of each
        step."""
        a, b = _coefficient("rayleigh.alpha", alpha), _coefficient("rayleigh.beta", beta)
        names = self._member_list("rayleigh.members", members)
        if a:  # C = alpha M is one matrix for the whole scene
            if members is not None:
                raise fail("rayleigh.members", "alpha (mass-proportional) acts on the whole scene: give members only "
                           "with beta", members)
            other = {d.alpha for d in self.dampings if d.kind == "rayleigh" and d.alpha} - {a}
            if other:
                raise fail("rayleigh.alpha", f"the scene has one mass-proportional alpha; an earlier damping gives "
                           f"{other.pop()!r}", alpha)
        d = Damping("rayleigh", a, b, names)
        self.dampings.append(d)
        return d

    def strain_rate_damping(self, axial: float = 0.0, bending: float = 0.0,
                            members: Sequence[str] | None = None) -> Damping:
        """Kelvin-Voigt damping of cable members for dynamics: axial force axial * eps_dot [axial in N s] and
        bending moment bending * kappa_dot [bending in N m^2 s] (strain rate of the member's axial measure,
        curvature-vector rate); it vanishes under rigid-body motion."""
        a = _coefficient("strain_rate_damping.axial", axial)
        b = _coefficient("strain_rate_damping.bending", bending)
        names = self._member_list("strain_rate_damping.members", members)
        for m in names if names is not None else list(self.members):
            if self.members[m].element == "beam3d":
                raise SceneError(f"strain_rate_damping: member {m!r} is a beam3d; strain-rate damping is defined for "
                                 "cable members (use rayleigh for beams)")
        d = Damping("strain_rate", members=names, axial=a, bending=b)
        self.dampings.append(d)
        return d

    def _member_list(self, field_name: str, members: Sequence[str] | str | None) -> list[str] | None:
        """None (all members) or the named members, each checked (errors name field_name[i])."""
        if members is None:
            return None
        names = [members] if isinstance(members, str) else list(members)
        for i, m in enumerate(names):
            self._member(m, f"{field_name}[{i}]")
        return names

    def _add_load(self, load: Load) -> Load:
        self.loads.append(load)
        return load

    # -- checks ------------------------------------------------------------------------------------------------
    def _member(self, name: str, field_name: str) -> Member:
        if not isinstance(name, str) or name not in self.members:
            raise fail(field_name, f"names no member; members: {sorted(self.members)}", name)
        return self.members[name]

    def check_at(self, member: str, at: Any, node_only: bool, field_name: str) -> None:
        """Refuse a location on a member unless it is 'start', 'end', a node index or (node_only=False) a material
        coordinate in [0, length] m; the message names field_name. MemberMesh.coordinate turns it into s [m]."""
        m = self._member(member, f"{field_name} member")
        if isinstance(at, str) and at in ("start", "end"):
            return
        if isinstance(at, (int, np.integer)) and not isinstance(at, (bool, np.bool_)):
            if not -m.n_nodes <= at < m.n_nodes:
                raise fail(field_name, f"member {member!r} has nodes 0..{m.n_nodes - 1}", at)
            return
        if not node_only and isinstance(at, (float, np.floating)):
            if not (math.isfinite(at) and 0 <= at <= m.length):
                raise fail(field_name, f"material coordinate must lie in [0, {m.length:g}] m", at)
            return
        raise fail(field_name, "expected 'start', 'end', a node index"
                   + ("" if node_only else " or a material coordinate in metres (float)"), at)

    def validate_for_statics(self, allow_free: bool = False) -> None:
        """Refuse scenes with a free rigid-body motion: every connected group of members needs a support.
        allow_free: only the other checks (a modal analysis of a free structure about its unloaded reference)."""
        if not self.members and not self.bodies:
            raise SceneError("scene has no members")
        if self.drives and self.water is None:  # (in water, position drives hold fairleads: ancf_sym.statics.water)
            raise SceneError(f"drives: {self.drives[0].name!r} prescribes motion in time (dynamics); solve the statics "
                             "without drives and torques and start the dynamic run from that result")
        groups = {name: {name} for name in self.members}
        for j in self.joints:
            ga, gb = groups[j.a[0]], groups[j.b[0]]
            if ga is not gb:
                ga |= gb
                for n in gb:
                    groups[n] = ga
        for j in self.body_joints:  # members tied to the same body move together
            if j.member is not None:
                for other in self.body_joints:
                    if other.body == j.body and other.member is not None and groups[other.member] is not groups[j.member]:
                        ga, gb = groups[j.member], groups[other.member]
                        ga |= gb
                        for n in gb:
                            groups[n] = ga
        if allow_free:
            return
        from ancf_sym.bodies.planar import connected_supported
        supported = {s.member for s in self.supports if s.kind in ("clamp", "pin")}
        if self.water is not None:  # in water the statics hold member-node position drives (fairleads) as pins
            supported |= {d.member for d in self.drives if type(d).__name__ == "PositionDrive" and d.member is not None}
        held = connected_supported(self)
        supported |= held
        for j in self.body_joints:  # a body pinned to a supported member is held
            if j.member is not None and groups[j.member] & supported:
                held.add(j.body)
        for name in self.bodies:
            if name not in held:
                raise SceneError(f"body {name!r} has a free rigid-body motion: it needs a joint to the ground "
                                 "(revolute; 3D: spherical, prismatic) or a pin to a supported member")
        for name, g in groups.items():
            if not g & supported:
                raise SceneError(f"member {name!r} has a free rigid-body motion: neither it nor a member joined to "
                                 "it has a support (clamp, pin)")


# Fields whose values reach the equations only as element parameters of the stiffness kernels (inputs of the
# compiled step graphs, ancf_sym.model.terms): E, G, poisson, I, Iy, Iz, J. A structure key leaves their values out (not
# whether each is given). Gravity likewise (the gravity term's parameters), but for whether each component is zero.
VALUE_FIELDS = {Material: frozenset(("E", "G", "poisson")), Section: frozenset(("I", "Iy", "Iz", "J"))}


def structure_spec_key(scene: Scene) -> tuple | None:
    """An exact key of the scene (every field of it, its members, supports, joints, loads and dampings) without
    the values of VALUE_FIELDS and gravity's, so that scenes that differ only in those share set-up work that does
    not read them (the reduced coordinates, mass matrix, kernel calls and compiled graphs of a dynamic run:
    ancf_sym.system.step_system). None where another part of the set-up reads those values: penalty supports
    and joints (scaled by EA and EI), rigid bodies (their weight), contacts and drives (keyed by the full set-up)."""
    if scene.contacts or scene.bodies or scene.body_joints or scene.drives or scene.water is not None or \
            any(s.method != "exact" for s in scene.supports) or any(j.method != "exact" for j in scene.joints):
        return None
    parts: list = [type(scene)]
    for k, v in vars(scene).items():  # (field name, value; a member as one tuple, its values in field order)
        if k == "members":
            for name, m in v.items():
                d = vars(m)
                member = [name, type(m), tuple(d)]
                for x in d.values():
                    names = VALUE_FIELDS.get(type(x))
                    member.append(x if names is None else  # (a material or section: its value fields given or not)
                                  (type(x), tuple(vars(x))) + tuple(u is None if f in names else u
                                                                    for f, u in vars(x).items()))
                parts += [k, tuple(member)]
        elif k == "gravity":
            parts += [k, tuple(bool(g != 0) for g in v)]
        else:
            parts += [k, v]
    return setup_cache.array_key(*parts)


def _values(name: str):
    return lambda o: (tuple, ((name, *vars(o).values()),))


def _array(a: np.ndarray):
    return a.__reduce_ex__(4) if a.dtype.hasobject else (tuple, ((a.dtype.str, a.shape, a.tobytes()),))


def _dispatch() -> dict:
    table = copyreg.dispatch_table.copy()
    table[np.ndarray] = _array
    for cls in (Material, Section, Member, Support, Joint, Load, PointMass, Damping, Scene):
        table[cls] = _values(f"{cls.__module__}.{cls.__qualname__}")
    return table


class _Fingerprint(pickle.Pickler):
    """pickle with the scene's dataclasses as (qualified name, attribute values) and arrays as (dtype, shape,
    bytes): equal bytes for equal content, without pickle's per-class global lookups (half the time: ~12 us
    against ~24 us for a one-member scene)."""
    dispatch_table = _dispatch()


def fingerprint(scene: Scene) -> bytes | None:
    """A digest of everything the scene holds (equal digests: equal scenes, to every bit of every value); None
    where a part of it cannot be serialised."""
    buf = io.BytesIO()
    try:
        _Fingerprint(buf, protocol=4).dump(scene)
    except (pickle.PicklingError, TypeError, AttributeError):
        return None
    return hashlib.sha1(buf.getvalue()).digest()
