"""A member's stiffness options in kernel effects, decoded in one place.

A member chooses an axial strain measure (`axial`: green | biot | decoupled, or None, spelled "none" in TOML),
whether it has bending and torsion stiffness, and for beam3d a beam method. `stiffness_effects` turns these names
into the (energy label, kernel effect) pairs of ancf_sym.registry; `AXIAL_STRAINS` says what else a strain measure
means to the other stages (the strain whose rate strain-rate damping uses, whether it needs bending stiffness);
`gauss_orders` which quadrature orders exist for a member's effects. The scene's checks, the TOML reader, the
energy terms, strain-rate damping and the statics' Biot start read these; no other module spells the names out.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ancf_sym.util.checks import SceneError, fail
from ancf_sym.registry import EFFECTS, FUSED_STRAINS, GAUSS_ORDERS


@dataclass(frozen=True)
class AxialStrain:
    name: str  # the user's value of `axial`
    effect: str  # the cable kernel effect (ancf_sym.registry)
    rate: str  # the strain whose rate strain-rate damping uses: "green" (r_x.r_x - 1)/2 or "biot" |r_x| - 1
    needs_bending: bool  # the energy sees only nodal stretches and the length: an element folds freely without EI
    doc: str


AXIAL_STRAINS: dict[str, AxialStrain] = {s.name: s for s in (
    AxialStrain("green", "axial_green", "green", False, "coupled Green strain (r_x.r_x - 1)/2"),
    AxialStrain("biot", "axial_biot", "biot", False, "coupled Biot strain |r_x| - 1"),
    AxialStrain("decoupled", "axial_decoupled", "biot", True,
                "decoupled strain of the equivalent rod through the nodal stretches (paper 000)"),
)}
AXIAL = tuple(AXIAL_STRAINS)  # the strain measures a member can use
NO_AXIAL = "none"  # axial = None (no axial stiffness) where the input has no null (TOML)
START_STRAIN = "biot"  # the measure the statics start from for the others (a cheaper Newton, ancf_sym.statics)
# the cable kernel effects of the other measures -> those of the start measure (the fused axial + bending ones too)
START_EFFECTS = {
    **{s.effect: AXIAL_STRAINS[START_STRAIN].effect for s in AXIAL_STRAINS.values() if s.name != START_STRAIN},
    **{f"elastic_{s}": f"elastic_{START_STRAIN}" for s in FUSED_STRAINS if s != START_STRAIN},
    # the decoupled strain's own equivalent rod with Biot strain: the coupled Biot solution lies outside the decoupled
    # Newton's basin on coarse meshes (6 elements: 13 + 21 iterations), this one inside it (9 + 2, measured)
    AXIAL_STRAINS["decoupled"].effect: "axial_decoupled_biot", "elastic_decoupled": "elastic_decoupled_biot"}
BEAM_METHODS = ("continuum", "elastic_line")


def axial_strain(value: Any, field_name: str) -> str | None:
    """The user's `axial` (a name of AXIAL, None or "none") as a name of AXIAL or None; errors name field_name."""
    if value is None or value == NO_AXIAL:
        return None
    if not isinstance(value, str) or value not in AXIAL_STRAINS:
        raise fail(field_name, f"must be one of {' | '.join(AXIAL)} or {NO_AXIAL!r} (None: no axial stiffness)",
                   value)
    return value


def stiffness_effects(element: str, axial: str | None, bending: bool, torsion: bool,
                      beam_method: str) -> list[tuple[str, str]]:
    """(energy label, kernel effect) of a member's stiffness terms. Cables: the axial measure's effect and
    bending. beam3d: the continuum method is one energy of the whole deformation gradient (axial, bending,
    torsion and shear together); the elastic-line method always has its centreline strains (line_strain, which
    carries the axial stiffness whatever `axial` says) and bending and torsion on request."""
    if element.startswith("cable"):
        if torsion:  # (a cable has no section orientation)
            raise SceneError(f"torsion needs element 'beam3d', not {element!r}")
        return ([("axial", AXIAL_STRAINS[axial].effect)] if axial is not None else []) + \
            ([("bending", "bending")] if bending else [])
    if beam_method == "continuum":
        return [("continuum", "continuum")]
    return [("axial", "line_strain")] + ([("bending", "line_bending")] if bending else []) + \
        ([("torsion", "line_torsion")] if torsion else [])


def gauss_orders(element: str, effects: list[tuple[str, str]]) -> tuple[int, ...]:
    """The Gauss orders every one of these effects is generated for (ancf_sym.registry); all orders where none
    of them has a quadrature choice."""
    orders = set(GAUSS_ORDERS)
    for _, effect in effects:
        g = EFFECTS[(element, effect)].gauss
        if g:
            orders &= set(g)
    return tuple(sorted(orders))
