"""What a failed run's last state says about why it failed, for the result's message.

A member without bending stiffness (a string) in compression has no stable shape: its wrinkles grow at the
mesh's shortest wavelength, at a rate no step size bounds, so Newton fails or the scheme creates energy
(docs/hard_cases.md, spinning bending-free cables). Where a failed run ends with such a member compressed, the
message names it and the two ways out, instead of leaving the user to suspect the integrator.
"""
from __future__ import annotations

import numpy as np

from ancf_sym.elements.quadrature import gauss01
from ancf_sym.model import fields
from ancf_sym.model.assembly import Assembly

# compressive strain counted: far above the round-off of a strain (1e-15) and far below any strain a string
# carries in tension; a string holds no compression of any size, so the exact level only filters round-off
COMPRESSION = -1e-9


def compressed_strings(asm: Assembly, x: np.ndarray) -> str:
    """'' or a sentence naming the bending-free members in compression at the full coordinates x (their share of
    Gauss points in compression and the largest compressive strain)."""
    xi = gauss01(3)[0]
    found = []
    for name, mm in asm.mesh.members.items():
        m = mm.member
        if m.bending or m.axial is None or not m.element.startswith("cable"):
            continue
        eps = fields.axial_strain(mm, asm.member_coordinates(x, name), xi)
        bad = eps < COMPRESSION
        if bad.any():
            found.append(f"{name!r} ({int(bad.any(axis=1).sum())} of {eps.shape[0]} elements, strain down to "
                         f"{float(eps.min()):.2g})")
    if not found:
        return ""
    return ("members without bending stiffness are in compression where the run stopped: " + ", ".join(found)
            + "; a string in compression has no stable shape (its wrinkles grow at the mesh's shortest wavelength): "
            "give it a bending stiffness, or resolve the motion with smaller steps")
