"""What kernels exist: element kinds, their effects and the parameter vector of each.

Plain data, no symbolic code: the loader, the build and the code generator all read it, so the names and the
order of `p` are defined once. Effect names are public API.
"""
from __future__ import annotations

from dataclasses import dataclass

DEFAULT_GAUSS = 5
# Extra Gauss orders emitted for the effects whose accuracy studies need them (cheap: one point-function each).
STUDY_GAUSS = (3, 4, 7)


@dataclass(frozen=True)
class Element:
    name: str
    dim: int  # spatial dimension of r
    ndof: int  # nodal coordinates per element
    dof_names: tuple[str, ...]
    description: str


@dataclass(frozen=True)
class Effect:
    element: str
    name: str
    params: tuple[str, ...]
    description: str
    gauss: tuple[int, ...] = ()  # quadrature orders emitted; () = exact/closed form, no quadrature choice
    elastic: bool = True  # elastic effects vanish under rigid-body motion
    parts: tuple[str, ...] = ()  # internal fused effect: the public effects it sums in one kernel (else ())
    obstacle: int = 0  # contact: coordinates of the obstacle (drum centre [, angle]) appended to the element's q
    rates: bool = False  # dissipation kernel: input [q; v] (coordinates and their velocities), see elements.contact

    @property
    def internal(self) -> bool:
        """Fused effects are an optimisation of the step graphs: scenes never name them."""
        return bool(self.parts)

    @property
    def default_gauss(self) -> int | None:
        return DEFAULT_GAUSS if DEFAULT_GAUSS in self.gauss else (self.gauss[0] if self.gauss else None)


def _cable_dofs(dim: int) -> tuple[str, ...]:
    axes = "xyz"[:dim]
    names = []
    for node in ("0", "1"):
        names += [f"r{a}{node}" for a in axes] + [f"rx_{a}{node}" for a in axes]
    return tuple(names)


def _beam_dofs() -> tuple[str, ...]:
    names = []
    for node in ("0", "1"):
        for vec in ("r", "r_x", "r_y", "r_z"):
            names += [f"{vec}{a}{node}" for a in "xyz"]
    return tuple(names)


ELEMENTS: dict[str, Element] = {
    "cable2d": Element("cable2d", 2, 8, _cable_dofs(2), "planar gradient-deficient ANCF cable, cubic Hermite"),
    "cable3d": Element("cable3d", 3, 12, _cable_dofs(3), "spatial gradient-deficient ANCF cable, cubic Hermite"),
    "beam3d": Element("beam3d", 3, 24, _beam_dofs(), "fully parameterised ANCF beam (paper 001), b x h section"),
}

GAUSS_ORDERS = (3, 4, 5, 7)  # Gauss points per element every quadrature kernel is generated for
_G = GAUSS_ORDERS  # short name for the tables below
# Axial strains whose quadrature kernel also exists fused with bending (elastic_<strain>: p = L, EA, EI): one
# B^T f_uu B per Gauss point, one accumulation and one mirror instead of two (bench/kernel_forms.py). The step
# graphs use it where a cable member has both effects at the same Gauss order (assembly.force_terms).
FUSED_STRAINS = ("green", "biot")
# The decoupled strain's axial energy is no density of (r_x, r_xx) but a function of three stretch measures (the
# nodal |r_x| and the deformed length): its kernel fused with bending (elastic_<strain>, p = L, EA, EI) chains its
# derivatives through them and adds the length's per-point Hessian to bending's (codegen.forms.stretch_kernel).
FUSED_STRETCH_STRAINS = ("decoupled", "decoupled_biot")


def _cable_effects(el: str, dim: int) -> list[Effect]:
    g_names = tuple(f"g{a}" for a in "xyz"[:dim])
    moment_params = ("L", "xi", "M", "t0x", "t0y") if dim == 2 else ("L", "xi", "M", "nx", "ny", "nz", "t0x", "t0y", "t0z")
    return [
        Effect(el, "axial_green", ("L", "EA"), "coupled Green strain eps=(r_x.r_x-1)/2, U=1/2 int EA eps^2", _G),
        Effect(el, "axial_biot", ("L", "EA"), "coupled Biot strain eps=|r_x|-1, U=1/2 int EA eps^2", _G),
        Effect(el, "axial_decoupled", ("L", "EA"),
               "decoupled strain of paper 000: equivalent rod q_D=[0,|r_x(0)|,L_D,|r_x(L)|]", _G),
        Effect(el, "axial_decoupled_biot", ("L", "EA"),
               "the decoupled strain's equivalent rod with Biot strain r_D,x - 1 (the statics' start for it)", _G),
        Effect(el, "bending", ("L", "EI"), "U=1/2 int EI |r_x x r_xx|^2/|r_x|^6", _G),
        Effect(el, "gravity", ("L", "rhoA") + g_names, "U=-int rhoA g.r dx (exact, linear in q)", elastic=False),
        Effect(el, "moment", moment_params,
               "potential -M*phi of a moment M turning the tangent r_x(xi) by phi from reference t0"
               + ("" if dim == 2 else " about axis n (angle of the projection on the plane normal to n)"),
               elastic=False),
    ] + [
        Effect(el, f"elastic_{strain}", ("L", "EA", "EI"),
               f"internal: axial_{strain} + bending as one density of (r_x, r_xx) (one kernel instead of two)",
               _G, parts=(f"axial_{strain}", "bending"))
        for strain in FUSED_STRAINS
    ] + [
        Effect(el, f"elastic_{strain}", ("L", "EA", "EI"),
               f"internal: axial_{strain} + bending in one kernel, chained through the stretches (one kernel "
               "instead of two)", _G, parts=(f"axial_{strain}", "bending"))
        for strain in FUSED_STRETCH_STRAINS
    ]


def _beam_effects() -> list[Effect]:
    return [
        Effect("beam3d", "continuum", ("L", "b", "h", "E", "nu", "J"),
               "continuum mechanics method, enhanced (locking-free): St. Venant-Kirchhoff on Green-Lagrange "
               "E=(J^T J-I)/2 with the Poisson coupling on the centreline only and the section shear scaled to "
               "torsion G J; 5x2x2 + 5 axis Gauss points", (5,)),
        Effect("beam3d", "line_strain", ("L", "b", "h", "E", "nu"),
               "elastic-line method: Green-Lagrange strains of the centreline (eps011, eps22, eps33, gamma012, "
               "gamma013, gamma23) times the section area", _G),
        Effect("beam3d", "line_bending", ("L", "EIy", "EIz"),
               "elastic-line bending, kappa_y=r_z.r_xx/(|r_z||r_x|^2), kappa_z=-r_y.r_xx/(|r_y||r_x|^2)", _G),
        Effect("beam3d", "line_torsion", ("L", "GIp"), "elastic-line torsion theta=(r_y'.r_z-r_y.r_z')/2", _G),
        Effect("beam3d", "gravity", ("L", "rhoA", "gx", "gy", "gz"), "U=-int rhoA g.r dx (exact)", elastic=False),
        Effect("beam3d", "moment_z", ("L", "xi", "M", "ref1", "ref2"),
               "paper 001 nodal moment about Z: potential -M*gamma, gamma = rotation of (r_y1, r_y2) at xi from ref",
               elastic=False),
        Effect("beam3d", "moment_y", ("L", "xi", "M", "ref3", "ref1"),
               "paper 001 nodal moment about Y: potential -M*beta, beta = rotation of (r_z3, r_z1) at xi from ref",
               elastic=False),
    ]


CONTACT_GAUSS = (3, 5, 7)  # contact points per element (Gauss points, weights w L)


def _contact_effects(el: str, dim: int) -> list[Effect]:
    """Centre line against the ground half-space n.r >= d and against a circle (2D) / cylinder of unit axis a (3D)
    whose centre c (and angle, for friction) are coordinates of the scene (fixed, driven or a rigid body's).
    Normal law k/2 delta^2 + 2/5 kh delta^2.5 per unit length; dissipation of damping c and regularised Coulomb
    friction (mu, velocity eps): input [q; v], gradient's v-part = the force (elements.contact)."""
    law = ("L", "k", "kh", "t")
    normal = tuple(f"n{a}" for a in "xyz"[:dim]) + ("d",)
    axis = ("R",) if dim == 2 else ("R", "ax", "ay", "az")
    friction = ("c", "mu", "eps")
    centre = tuple(f"c{a}" for a in "xyz"[:dim])
    offset = ("sx", "sy", "sz")  # a spatial body's drum: its axis point in body components
    return [
        Effect(el, "contact_ground", law + normal, "ground contact energy of the centre line (penalty/Hertz)",
               CONTACT_GAUSS, elastic=False),
        Effect(el, "contact_ground_friction", law + normal + friction,
               "ground contact damping + regularised Coulomb friction: dissipation function of [q; v]",
               CONTACT_GAUSS, elastic=False, rates=True),
        Effect(el, "contact_circle", law + axis, "contact energy with a drum of centre c (appended to q)",
               CONTACT_GAUSS, elastic=False, obstacle=dim),
        Effect(el, "contact_circle_friction", law + axis + friction,
               "drum contact damping + regularised Coulomb friction: dissipation of [q, c, angle; v, c', omega]",
               CONTACT_GAUSS, elastic=False, obstacle=dim + 1, rates=True),
        # a drum carried by a planar rigid body (natural coordinates x, y, cos, sin; centre at its centre of mass):
        # the body's spin c s' - s c' inside the density (the fields stay linear in the inputs)
        *([Effect(el, "contact_body_friction", law + axis + friction,
                  "body-carried drum damping + regularised Coulomb friction: dissipation of [q, x, y, c, s; rates]",
                  CONTACT_GAUSS, elastic=False, obstacle=4, rates=True)] if dim == 2 else []),
        # a drum carried by a spatial rigid body (natural coordinates r, e1, e2, e3, ancf_sym.bodies.spatial): axis
        # a = sum a_k e_k through the body point r + sum s_k e_k (a, s in body components, parameters)
        *([Effect(el, "contact_body_drum", law + axis + offset,
                  "spatial-body-carried drum contact energy: [q, r, e1, e2, e3]", CONTACT_GAUSS, elastic=False,
                  obstacle=12),
           Effect(el, "contact_body_drum_friction", law + axis + friction + offset,
                  "spatial-body-carried drum damping + regularised Coulomb friction: dissipation of "
                  "[q, r, e1, e2, e3; rates] (the body's spin and tumbling in the relative velocity)", CONTACT_GAUSS,
                  elastic=False, obstacle=12, rates=True)] if dim == 3 else []),
        # statics with exact contact: the gap of one centre-line point (at xi, a parameter) outside a drum, a
        # constraint g >= 0 of IPOPT (its Hessian weighted by the multiplier); the centre is an input, so one kernel
        # serves a fixed drum (constant centre) and a planar body's drum (its x, y)
        Effect(el, "contact_circle_gap", ("L", "xi", "t") + axis, "gap |r(xi) - c|_perp - R - t of a centre-line "
               "point outside a drum of centre c (appended to q): a unilateral constraint of statics", elastic=False,
               obstacle=dim),
        *([Effect(el, "contact_body_drum_gap", ("L", "xi", "t") + axis + offset,
                  "gap of a centre-line point outside the drum of a spatial body: [q, r, e1, e2, e3]",
                  elastic=False, obstacle=12)] if dim == 3 else []),
        # a fixed drum: the same densities with the centre as a parameter (no obstacle coordinates in the scene)
        Effect(el, "contact_drum", law + axis + centre, "contact energy with a fixed drum of centre c (in p)",
               CONTACT_GAUSS, elastic=False),
        Effect(el, "contact_drum_friction", law + axis + friction + centre,
               "fixed drum contact damping + regularised Coulomb friction: dissipation function of [q; v]",
               CONTACT_GAUSS, elastic=False, rates=True),
    ]


EFFECTS: dict[tuple[str, str], Effect] = {
    (e.element, e.name): e
    for e in _cable_effects("cable2d", 2) + _cable_effects("cable3d", 3) + _beam_effects()
    + _contact_effects("cable2d", 2) + _contact_effects("cable3d", 3) + _contact_effects("beam3d", 3)
}


def input_size(element: str, effect: str) -> int:
    """Length of a kernel's q: the element's coordinates, the obstacle's, and for dissipation kernels both again
    as velocities."""
    eff = EFFECTS[(element, effect)]
    n = ELEMENTS[element].ndof + eff.obstacle
    return 2 * n if eff.rates else n

MASS_PARAMS: dict[str, tuple[str, ...]] = {
    "cable2d": ("L", "rhoA"),
    "cable3d": ("L", "rhoA"),
    "beam3d": ("L", "b", "h", "rho"),
}


# Effects whose libraries also carry <name>_hvp (third derivatives, for the dynamics constraints of optimal
# control): the cables' elastic effects at the default quadrature order.
THIRD_DERIVATIVE_EFFECTS = ("axial_green", "axial_biot", "axial_decoupled", "bending")
# Constraint kernels with the same companion: the cables' drum gap (the change of the exact contact rows' curvature
# along the static sensitivity, in the frequencies' derivative with exact drum contact).
THIRD_DERIVATIVE_GAPS = ("contact_circle_gap",)


# The beam3d elastic energies carry it too (emitted in point form, codegen.hvp_forms): the change of a
# stiffness-proportional Rayleigh damping beta K_el(q_n) v with q_n in the dynamic sensitivities.
THIRD_DERIVATIVE_BEAM_EFFECTS = ("line_strain", "line_bending", "line_torsion", "continuum")


def has_third_derivatives(element: str, effect: str, gauss: int | None) -> bool:
    eff = EFFECTS[(element, effect)]
    if element == "beam3d":
        return effect in THIRD_DERIVATIVE_BEAM_EFFECTS and gauss in (None, eff.default_gauss)
    return element.startswith("cable") and effect in THIRD_DERIVATIVE_EFFECTS + THIRD_DERIVATIVE_GAPS and \
        gauss in (None, eff.default_gauss)


def fused_effect(element: str, effects: tuple[str, ...]) -> str | None:
    """The internal effect summing exactly `effects` (in any order) on `element`, or None."""
    for (el, ef), eff in EFFECTS.items():
        if el == element and eff.parts and sorted(eff.parts) == sorted(effects):
            return ef
    return None


# Batched kernels (codegen.batch): <function>_x4 evaluates BATCH_LANES elements per call in SIMD lanes. Emitted at
# the default quadrature order for what the dynamics step graphs call at every step or output: the fused elastic
# effects' kernel and _grad companion, and the _energy companion of the cables' public quadrature effects (the
# energies per effect at the output times); and the kernel itself of bending (cables without axial stiffness) and
# of axial_decoupled[_biot] (the unfused calls, StepSystem(fuse=False), the fused kernel's reference in
# bench/decoupled_fused.py). Elsewhere the graphs map the one-element function.
# A dissipation kernel's (Effect.rates) companion <name>_rows: (z, p) -> (force dD/dv, [df/dq, df/dv]), the rows of
# its Hessian the dynamics' step uses (codegen.forms.rates_rows)
ROWS_SUFFIX = "_rows"
BATCH_LANES = 4
BATCH_SUFFIX = f"_x{BATCH_LANES}"


def batched(element: str, effect: str, gauss: int | None) -> tuple[str, ...]:
    """Companion suffixes ("" = the kernel itself, "_grad", "_energy") that have a batched version."""
    eff = EFFECTS[(element, effect)]
    if gauss not in (None, eff.default_gauss) or not element.startswith("cable"):
        return ()
    if eff.internal:
        return ("", "_grad")
    if effect == "bending":
        return ("", "_energy")
    if effect in ("axial_green", "axial_biot"):
        return ("_energy",)
    if effect in ("axial_decoupled", "axial_decoupled_biot"):
        return ("",)
    return ()


def has_batch(element: str, effect: str, gauss: int | None, companion: str = "") -> bool:
    return companion in batched(element, effect, gauss)


def kernel_name(element: str, effect: str, gauss: int | None = None) -> str:
    eff = EFFECTS[(element, effect)]
    if gauss is None or gauss == eff.default_gauss or not eff.gauss:
        return f"{element}_{effect}"
    return f"{element}_{effect}_g{gauss}"


def library_name(element: str, effect: str) -> str:
    """The shared library (and C file) holding every quadrature order of one (element, effect): the orders share
    their point function, which CasADi then emits once."""
    return f"{element}_{effect}"


def all_kernels() -> list[tuple[str, str, int | None]]:
    """(element, effect, gauss) for every kernel the generator emits, in a fixed order."""
    out = []
    for (el, ef), eff in EFFECTS.items():
        if not eff.gauss:
            out.append((el, ef, None))
        else:
            out.append((el, ef, eff.default_gauss))
            out += [(el, ef, g) for g in eff.gauss if g != eff.default_gauss]
    return out


# Banded LDL^T kernels (codegen.band; ancf_sym.system.band): (half-bandwidth w, columns per call m). w = 7: a chain of
# 4-coordinate nodes (planar cables) in its natural order.
BAND_LDL = ((7, 128),)
BAND_LIBRARY = "ancf_band"


def band_name(kind: str, w: int, m: int) -> str:
    """Name of a banded LDL^T kernel: kind "fwd" (factorisation, forward substitution) or "bwd" (back substitution)."""
    return f"band_ldl_{kind}_w{w}_m{m}"
