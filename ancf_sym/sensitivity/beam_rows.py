"""d(kernel parameters)/dp of a beam3d member for its material's E, poisson, G and its section's b, h.

model.terms gives a beam3d member the rows continuum (L, b, h, E, nu, J), line_strain (L, b, h, E, nu),
line_bending (L, E Iy, E Iz), line_torsion (L, G J) and gravity (L, rho A, g); its mass kernel takes (L, b, h, rho).
The scene's numbers reach them through nu = poisson (or E / 2G - 1 with G given), G = E / 2(1 + nu) (or given), and
for a shape = "rectangle" section A = b h, Iy = b h^3/12, Iz = h b^3/12 and St. Venant's J of the rectangle
(scene.builder.Section.rectangle: J = a c^3 (1/3 - 0.21 c/a (1 - c^4/12a^4)), a = max(b, h), c = min(b, h)),
differentiated here by hand; a section that gives area, Iy, Iz, J itself keeps them when b or h change (only the
continuum, line-strain and mass kernels, and a contact's default thickness h/2, see b and h), and its own area
(weight), I, Iy, Iz (bending) and J (torsion, the continuum's torsion scaling) are parameters too.
"""
from __future__ import annotations

import numpy as np

MATERIAL_KEYS = ("E", "poisson", "G")
SECTION_KEYS = ("b", "h")
GIVEN_SECTION_KEYS = ("area", "I", "Iy", "Iz", "J")  # of a section that gives them (no shape)


def _rectangle_J_derivatives(b: float, h: float) -> tuple[float, float]:
    """(dJ/db, dJ/dh) of Section.rectangle's J (a = max, c = min: J = a c^3/3 - 0.21 c^4 + 0.0175 c^8/a^4)."""
    a, c = max(b, h), min(b, h)
    da = c**3 / 3 - 0.07 * c**8 / a**5
    dc = a * c**2 - 0.84 * c**3 + 0.14 * c**7 / a**4
    return (da, dc) if b > h else (dc, da)


def base_derivatives(member, key: str, shape: str | None, given: tuple = ()) -> dict[str, float] | str:
    """d(E, nu, G, b, h, A, Iy, Iz, J)/dp of the member's quantities for p its material's or section's `key`
    (given: the keys the section's table gives); a string: why that is not differentiable."""
    mat, sec = member.material, member.section
    d = dict.fromkeys(("E", "nu", "G", "b", "h", "A", "Iy", "Iz", "J"), 0.0)
    E, nu, G = mat.E, mat.nu, mat.shear_modulus
    if key == "E":
        d["E"] = 1.0
        if mat.G is not None:  # nu = E / 2G - 1
            d["nu"] = 1.0 / (2.0 * mat.G)
        else:
            d["G"] = G / E
    elif key == "poisson":
        d["nu"], d["G"] = 1.0, -G / (1.0 + nu)
    elif key == "G":
        d["G"], d["nu"] = 1.0, -E / (2.0 * mat.G**2)
    elif key in SECTION_KEYS:
        b, h = sec.b, sec.h
        d[key] = 1.0
        if shape == "rectangle":
            if b == h:
                return "the rectangle's torsion constant J has a kink at b = h (max/min of b and h swap there)"
            if key == "b":
                d["A"], d["Iy"], d["Iz"] = h, h**3 / 12, h * b**2 / 4
                d["J"] = _rectangle_J_derivatives(b, h)[0]
            else:
                d["A"], d["Iy"], d["Iz"] = b, b * h**2 / 4, b**3 / 12
                d["J"] = _rectangle_J_derivatives(b, h)[1]
        elif shape is not None:
            return f"a {shape!r} section's b x h follow from its own keys (differentiate those)"
        elif sec.J is None:  # (the continuum kernel then takes the rectangle's J: model.terms)
            if b == h:
                return "the rectangle's torsion constant J has a kink at b = h (max/min of b and h swap there)"
            d["J"] = _rectangle_J_derivatives(b, h)[0 if key == "b" else 1]
    elif key in GIVEN_SECTION_KEYS and shape is None:
        # Section: I sets Iy and Iz where not given, Iy alone also Iz (and Iz alone Iy), J = Iy + Iz where not given
        if key == "area":
            d["A"] = 1.0
        elif key == "J":
            d["J"] = 1.0
        else:
            d["Iy"] = float(key == "Iy" or (key in ("I", "Iz") and "Iy" not in given))
            d["Iz"] = float(key == "Iz" or (key in ("I", "Iy") and "Iz" not in given))
            if "J" not in given:
                d["J"] = d["Iy"] + d["Iz"]
    else:
        return f"not a differentiable key of a{' ' + shape if shape else ''} beam3d section"
    return d


def row_derivative(effect: str, member, d: dict[str, float], n_params: int) -> np.ndarray | None:
    """d(parameter row)/dp of one of the member's terms (None: not a beam term handled here)."""
    mat, sec = member.material, member.section
    E, G = mat.E, mat.shear_modulus
    J = sec.J
    if effect == "continuum":
        row = [0.0, d["b"], d["h"], d["E"], d["nu"], d["J"]]
    elif effect == "line_strain":
        row = [0.0, d["b"], d["h"], d["E"], d["nu"]]
    elif effect == "line_bending":
        row = [0.0, d["E"] * sec.Iy + E * d["Iy"], d["E"] * sec.Iz + E * d["Iz"]]
    elif effect == "line_torsion":
        row = [0.0, d["G"] * J + G * d["J"]]
    elif effect == "gravity":
        row = [0.0, mat.density * d["A"]] + [0.0] * (n_params - 2)
    else:
        return None
    return np.asarray(row, float)


def mass_direction(member, d: dict[str, float]) -> np.ndarray:
    """d(mass parameters (L, b, h, rho))/dp."""
    return np.array([0.0, d["b"], d["h"], 0.0])
