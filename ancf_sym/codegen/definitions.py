"""Which symbolic energy builds which kernel: (element, effect, gauss) -> casadi.Function (q, p) -> (e, g, H)."""
from __future__ import annotations

import casadi as ca

from ancf_sym import registry
from ancf_sym.elements import beam, cable, contact
from ancf_sym.elements.quadrature import gauss01
from ancf_sym.codegen import forms, hvp_forms


def _cable_station(effect: str, dim: int):
    def station(q, p, xi, w):
        L, k = p[0], p[1]
        rx = cable.slope(q, L, xi, dim)
        if effect == "axial_green":
            yield rx, lambda v, p: cable.green_density(v, p[1]), w * L
        elif effect == "axial_biot":
            yield rx, lambda v, p: cable.biot_density(v, p[1]), w * L
        elif effect == "bending":
            u = ca.vertcat(rx, cable.curvature_vector(q, L, xi, dim))
            yield u, lambda v, p: cable.bending_density(v[:dim], v[dim:], p[1]), w * L
        elif effect in FUSED:
            # axial + bending as one density of u = (r_x, r_xx), p = (L, EA, EI): one B^T f_uu B per point
            axial = FUSED[effect]
            u = ca.vertcat(rx, cable.curvature_vector(q, L, xi, dim))
            yield u, lambda v, p: axial(v[:dim], p[1]) + cable.bending_density(v[:dim], v[dim:], p[2]), w * L
        else:
            raise KeyError(effect)
    return station


# Gauss points per section direction of the continuum beam. The section part's strains are linear in y, z (E_xy, E_xz)
# or quadratic (E_xx: the fibres' second-order term y^2 |r_y,x|^2 / 2); 2 x 2 points integrate every term of its
# energy exactly except the square of that second-order term, relative (kappa d)^2 / 60 of the bending energy (d the
# section depth; < 2e-5 while the fibre strains kappa d / 2 stay below 1 %), at half the cost of 3 x 3 (measured:
# 35 500 vs 63 400 SX instructions).
SECTION_GAUSS = 2


def beam_station(effect: str):
    def station(q, p, xi, w):
        L = p[0]
        if effect == "continuum":
            # enhanced continuum mechanics (elements/beam.py): the Poisson-free strains that vary over the section
            # on SECTION_GAUSS^2 section points, the rest of the 3D law on the centreline
            b, h = p[1], p[2]
            ys, wy = gauss01(SECTION_GAUSS)
            section = lambda v, p: beam.ecm_section_density(v[0:3], v[3:6], v[6:9], p[3], p[4],
                                                            beam.torsion_factor(p[1], p[2], p[5]))
            for yy, w2 in zip(ys, wy):
                for zz, w3 in zip(ys, wy):
                    rx, ry, rz = beam.gradients(q, L, xi, (yy - 0.5) * b, (zz - 0.5) * h)
                    yield ca.vertcat(rx, ry, rz), section, w * w2 * w3 * L * b * h
            axis = lambda v, p: beam.ecm_axis_density(v[0:3], v[3:6], v[6:9], p[3], p[4],
                                                      beam.torsion_factor(p[1], p[2], p[5]))
            yield ca.vertcat(*beam.gradients(q, L, xi, 0, 0)), axis, w * L * b * h
            return
        rx, ry, rz, rxx, ryx, rzx = beam.line_fields(q, L, xi)
        if effect == "line_strain":
            area = p[1] * p[2]
            yield ca.vertcat(rx, ry, rz), lambda v, p: beam.svk_density(v[0:3], v[3:6], v[6:9], p[3], p[4]), w * L * area
        elif effect == "line_bending":
            dens = lambda v, p: beam.line_bending_density(v[0:3], v[3:6], v[6:9], v[9:12], p[1], p[2])
            yield ca.vertcat(rx, ry, rz, rxx), dens, w * L
        elif effect == "line_torsion":
            dens = lambda v, p: beam.torsion_density(v[0:3], v[3:6], v[6:9], v[9:12], p[1])
            yield ca.vertcat(ry, rz, ryx, rzx), dens, w * L
        else:
            raise KeyError(effect)
    return station


def _contact_station(element: str, effect: str):
    """Contact at a Gauss point: fields r - c (and r' - c', omega) are linear in [q, obstacle; v, rates]."""
    el = registry.ELEMENTS[element]
    nd, dim, eff = el.ndof, el.dim, registry.EFFECTS[(element, effect)]
    n = nd + eff.obstacle
    centre = cable.position if element.startswith("cable") else (lambda q, L, xi, dim: beam.centreline(q, L, xi))

    def station(z, p, xi, w):
        L = p[0]
        r = centre(z[:nd], L, xi, dim)
        c = z[nd:nd + dim] if eff.obstacle else 0
        if effect.startswith("contact_drum"):  # fixed drum: centre after (law, axis[, friction]) in p
            c = p[len(eff.params) - dim:]
        if effect.startswith("contact_body_drum"):  # a spatial body's drum: u = (r - r_b, E[, r' - r_b', E'])
            body = z[nd:nd + 12]
            if not eff.rates:
                yield ca.vertcat(r - body[:3], body[3:]), contact.body_drum_energy, w * L
                return
            bv = z[n + nd:n + nd + 12]
            v = centre(z[n:n + nd], L, xi, dim)
            yield ca.vertcat(r - body[:3], body[3:], v - bv[:3], bv[3:]), contact.body_drum_dissipation, w * L
            return
        if not eff.rates:
            dens = contact.ground_energy if effect == "contact_ground" else contact.circle_energy
            yield r - c, lambda u, p: dens(u, p, dim), w * L
            return
        v = centre(z[n:n + nd], L, xi, dim)
        if effect == "contact_ground_friction":
            yield ca.vertcat(r, v), lambda u, p: contact.ground_dissipation(u[:dim], u[dim:], p, dim), w * L
        elif effect == "contact_body_friction":  # u = (r - c, r' - c', c, s, c', s'): spin c s' - s c' in the density
            b, bv = z[nd:nd + 4], z[n + nd:n + nd + 4]
            yield ca.vertcat(r - c, v - bv[:2], b[2:], bv[2:]), lambda u, p: contact.circle_dissipation(
                u[:2], u[2:4], u[4] * u[7] - u[5] * u[6], p, 2), w * L
        else:
            moving = effect == "contact_circle_friction"  # else a fixed drum: c' = 0, omega = 0
            u = ca.vertcat(r - c, v - z[n + nd:n + nd + dim], z[n + nd + dim]) if moving else ca.vertcat(r - c, v, 0)
            yield u, lambda u, p: contact.circle_dissipation(u[:dim], u[dim:2 * dim], u[2 * dim], p, dim), w * L
    return station


CONTACT = {ef for (el, ef), e in registry.EFFECTS.items() if ef.startswith("contact_") and e.gauss}  # (gaps: direct)


# internal fused effects (registry Effect.parts): axial density of the strain measure + bending density
FUSED = {f"elastic_{s}": {"green": cable.green_density, "biot": cable.biot_density}[s] for s in registry.FUSED_STRAINS}
_QUADRATURE = {"axial_green", "axial_biot", "bending", "continuum", "line_strain", "line_bending", "line_torsion",
               *FUSED, *CONTACT}


def _gap(element: str, effect: str):
    """Gap of the centre-line point at xi = p[1] outside a drum (elements.contact.circle_gap / body_drum_gap), the
    drum's centre or carrying body's coordinates after the element's in q."""
    el = registry.ELEMENTS[element]
    nd, dim = el.ndof, el.dim
    centre = cable.position if element.startswith("cable") else (lambda q, L, xi, dim: beam.centreline(q, L, xi))

    def gap(z, p):
        r = centre(z[:nd], p[0], p[1], dim)
        if effect == "contact_body_drum_gap":
            return contact.body_drum_gap(ca.vertcat(r - z[nd:nd + 3], z[nd + 3:nd + 12]), p)
        return contact.circle_gap(r - z[nd:nd + dim], p, dim)
    return gap


# the strain of each decoupled variant's rod energy (elements.cable.rod_energy of its stretches)
ROD_STRAIN = {"decoupled": "green", "decoupled_biot": "biot"}
# internal fused effects of the decoupled strain: axial_<strain> + bending through the stretches (forms.stretch_kernel)
STRETCH = {f"elastic_{s}": ROD_STRAIN[s] for s in registry.FUSED_STRETCH_STRAINS}


def _stretch_kernel(name: str, element: str, effect: str, gauss: int) -> ca.Function:
    """axial_decoupled[_biot] + bending of a cable in one kernel, p = (L, EA, EI): the rod energy of the stretches
    (a, L_D, c) (elements.cable.rod_energy; L_D by the same Gauss points) plus the bending density, in the
    coordinates y = ((r(L) - r(0))/L, r_x(0), r_x(L)) where the fields (r_x, L r_xx) have numeric coefficients."""
    dim, strain = registry.ELEMENTS[element].dim, STRETCH[effect]
    zero = ca.SX.zeros(dim)

    def coordinates(q, p):
        r0, t0, r1, t1 = cable.nodal(q, dim)
        return ca.vertcat((r1 - r0) / p[0], t0, t1)

    def basis(xi):  # (r_x, L r_xx) = B y: the element's fields at L = 1 with r(0) = 0, r(1) = the chord
        y = ca.SX.sym("y", 3 * dim)
        qy = ca.vertcat(zero, y[dim:2 * dim], y[:dim], y[2 * dim:])
        return ca.evalf(ca.jacobian(ca.vertcat(cable.slope(qy, 1, xi, dim), cable.curvature_vector(qy, 1, xi, dim)), y))

    invariants = lambda v: cable.bending_invariants(v[:dim], v[dim:])  # (|r_x|^2, r_x x L r_xx)
    ends = lambda y: (y[dim:2 * dim], y[2 * dim:])
    rod = lambda s, p: cable.rod_energy(s[0], s[1], s[2], p[0], p[1], gauss, strain)
    bend = lambda z, p: cable.bending_of_invariants(z[0], z[1:] / p[0], p[2])
    return forms.stretch_kernel(name, registry.ELEMENTS[element].ndof, 3, gauss, coordinates, basis, invariants,
                                ends, rod, bend)


def _direct_energy(element: str, effect: str, gauss: int | None):
    el = registry.ELEMENTS[element]
    if effect.endswith("_gap"):
        return _gap(element, effect)
    if element.startswith("cable"):
        dim = el.dim
        if effect.removeprefix("axial_") in ROD_STRAIN:
            strain = ROD_STRAIN[effect.removeprefix("axial_")]
            return lambda q, p: cable.decoupled_energy(q, p, dim, gauss, strain)
        if effect == "gravity":
            return lambda q, p: cable.gravity_energy(q, p, dim)
        if effect == "moment":
            return lambda q, p: cable.moment_energy(q, p, dim)
    else:
        if effect == "gravity":
            return beam.gravity_energy
        if effect == "moment_z":
            return beam.moment_z_energy
        if effect == "moment_y":
            return beam.moment_y_energy
    raise KeyError((element, effect))


_POINT_CACHE: dict[tuple, ca.Function | tuple] = {}


def point_function(element: str, effect: str) -> ca.Function:
    key = (element, effect)
    if key not in _POINT_CACHE:
        el, eff = registry.ELEMENTS[element], registry.EFFECTS[key]
        if effect in CONTACT:
            station = _contact_station(element, effect)
        else:
            station = _cable_station(effect, el.dim) if element.startswith("cable") else beam_station(effect)
        _POINT_CACHE[key] = forms.point_function(f"{element}_{effect}_point", registry.input_size(element, effect),
                                                 len(eff.params), station)
    return _POINT_CACHE[key]


def kernel(element: str, effect: str, gauss: int | None = None) -> ca.Function:
    """The symbolic kernel (q, p) -> (energy, gradient, hessian) for one (element, effect, quadrature order)."""
    el, eff = registry.ELEMENTS[element], registry.EFFECTS[(element, effect)]
    gauss = gauss or eff.default_gauss
    name = registry.kernel_name(element, effect, gauss)
    if effect in STRETCH:
        return _stretch_kernel(name, element, effect, gauss)
    if effect in _QUADRATURE:
        k = forms.quadrature_kernel(name, point_function(element, effect), gauss)
        # Small kernels run 1.6-3x faster as one straight-line SX function (no per-point calls, the Hessian mirror
        # is free); the big beam kernels keep the calls: expanded they compile 4-7x longer for no gain
        # (bench/kernel_forms.py, bench/RESULTS.md).
        small = element.startswith("cable") or effect == "line_torsion" or effect in CONTACT
        return k.expand(name, {}) if small else k
    return forms.direct_kernel(name, registry.input_size(element, effect), len(eff.params),
                               _direct_energy(element, effect, gauss))


def hvp(element: str, effect: str, gauss: int | None) -> ca.Function | None:
    """The <name>_hvp companion in point form (codegen.hvp_forms) for the beam3d elastic energies; None: the kernel's
    own third derivative (codegen.forms.hvp_function, the cables')."""
    if element != "beam3d":
        return None
    eff = registry.EFFECTS[(element, effect)]
    pt = hvp_forms.point_hvp_function(f"{element}_{effect}_hvp_point", registry.input_size(element, effect),
                                      len(eff.params), beam_station(effect))
    return hvp_forms.quadrature_hvp(registry.kernel_name(element, effect, gauss) + "_hvp", pt,
                                    gauss or eff.default_gauss)


def mass(element: str) -> ca.Function:
    el = registry.ELEMENTS[element]
    p = ca.SX.sym("p", len(registry.MASS_PARAMS[element]))
    M = cable.mass_matrix(p, el.dim) if element.startswith("cable") else beam.mass_matrix(p)
    return ca.Function(f"{element}_mass", [p], [ca.densify(M)], ["p"], ["mass"])


def lower_orders(element: str, effect: str, gauss: int | None, k: ca.Function) -> tuple[ca.Function, ca.Function]:
    """The kernel's energy-only and energy+gradient functions (see forms.lower_orders)."""
    eff = registry.EFFECTS[(element, effect)]
    points = None
    if effect in _QUADRATURE:
        key = (element, effect, "pruned")
        if key not in _POINT_CACHE:  # one object per effect, so a library holding all orders emits it once
            pt = point_function(element, effect)
            _POINT_CACHE[key] = (forms.pruned(pt, 1, pt.name() + "_e"), forms.pruned(pt, 2, pt.name() + "_eg"))
        points = _POINT_CACHE[key]
    return forms.lower_orders(k, points, gauss or eff.default_gauss)


def rates_rows(element: str, effect: str, gauss: int | None, k: ca.Function) -> ca.Function | None:
    """A dissipation kernel's <name>_rows companion (forms.rates_rows: the force and its q- and v-Jacobian blocks),
    None for other effects."""
    if not registry.EFFECTS[(element, effect)].rates:
        return None
    return forms.rates_rows(k if k.is_a("SXFunction") else k.expand(), k.name() + registry.ROWS_SUFFIX)
