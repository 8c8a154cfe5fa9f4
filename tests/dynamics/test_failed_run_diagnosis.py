"""A failed run names a compressed string (ancf_sym.dynamics.diagnosis): the pinned bending-free wire spinning at
1 rad/s under gravity (docs/hard_cases.md) falls slack and whips, its nodes' axial forces swing into kilonewtons of
compression, and generalized-alpha at 1 ms cannot follow (newton_failed or energy_blowup). The user reads why."""
from __future__ import annotations

import numpy as np

from ancf_sym import Material, Scene, Section
from ancf_sym.dynamics import run_dynamics
from ancf_sym.dynamics.diagnosis import compressed_strings
from ancf_sym.model.assembly import Assembly


def wire(bending: bool) -> Scene:
    s = Scene(dim=2, gravity=(0, -9.81))
    s.member("c", [(0, 0), (1, 0)], 10, Material(E=200e9, density=7800), Section.circle(0.005), axial="green",
             bending=bending, gravity=True)
    s.pin("c", "start")
    return s


def test_failed_spinning_string_names_the_compression():
    r = run_dynamics(wire(False), {"integrator": "generalized_alpha", "rho_inf": 0.9, "dt": 1e-3, "t_end": 1.0,
                                   "initial": [{"member": "c", "omega": 1.0, "centre": [0.0, 0.0]}]})
    assert not r.success, r.summary()  # (the documented failure; a run that completed would need no diagnosis)
    assert "'c'" in r.message and "compression" in r.message and "bending stiffness" in r.message, r.message


def test_compressed_strings_reads_the_strain():
    """Shortening the straight wire by 1e-4 (compression) is named, stretching it is not, nor is a member with
    bending stiffness (a compressed beam has a stable shape below its buckling load)."""
    for bending, scale, named in ((False, 1 - 1e-4, True), (False, 1 + 1e-4, False), (True, 1 - 1e-4, False)):
        asm = Assembly(wire(bending))
        x = np.array(asm.x0, float)
        mm = asm.mesh.members["c"]
        xn = x[mm.offset:mm.offset + mm.x0.size].reshape(mm.n_nodes, mm.node_size)
        xn[:, 0] *= scale  # (x and its slope scaled: the same strain everywhere)
        xn[:, 2] *= scale
        text = compressed_strings(asm, x)
        assert bool(text) == named, text
