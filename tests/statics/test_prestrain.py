"""A prestrained member: the polyline is the member stretched by 1 + prestrain (a taut string between pins)."""
from __future__ import annotations

import numpy as np

from ancf_sym import Material, Scene, Section, solve_static
from ancf_sym.model.assembly import Assembly


def string(prestrain, axial="biot", gravity=(0.0, 0.0)):
    s = Scene(dim=2, gravity=gravity)
    sec = Section.circle(0.2e-3)
    s.member("s", [(0, 0), (1, 0)], 20, Material(E=200e9, density=7800), sec, axial=axial, bending=True,
             prestrain=prestrain)
    s.pin("s", "start")
    s.pin("s", "end")
    return s, 200e9 * sec.area


def test_reference_state_carries_the_tension():
    """Biot strain: the pins hold N = EA eps0 (5 N for paper 002's string), the mass is the unstretched one."""
    EA = 200e9 * np.pi * (0.2e-3) ** 2 / 4
    eps0 = 5.0 / EA
    s, _ = string(eps0)
    a = Assembly(s)
    g = a.evaluate(a.x0).gradient
    mm = a.mesh.members["s"]
    end_force = g[mm.node_dofs(mm.n_nodes - 1)][0]  # d Pi / d x at the right pin = the string's pull on it
    assert abs(end_force - 5.0) < 1e-9 * 5.0
    assert abs(s.members["s"].length - 1.0 / (1 + eps0)) < 1e-15
    M = a.mass_matrix()
    ux = np.zeros(a.n)
    ux[0::4] = 1.0  # rigid translation in x: kinetic energy 1/2 m
    assert abs(ux @ M @ ux - 7800 * np.pi * (0.2e-3) ** 2 / 4 * s.members["s"].length) < 1e-12


def test_taut_string_sags_as_a_string():
    """Under gravity the taut string sags by w = q l^2 / (8 T) at midspan (shallow parabola, T >> q l)."""
    EA = 200e9 * np.pi * (0.2e-3) ** 2 / 4
    s, _ = string(5.0 / EA, gravity=(0.0, -9.81))
    r = solve_static(s)
    q = 7800 * np.pi * (0.2e-3) ** 2 / 4 * 9.81 / (1 + 5.0 / EA)  # weight per unit stretched length
    w = r.nodes("s")[10][1]
    assert r.success and abs(w + q / (8 * 5.0)) < 0.01 * q / (8 * 5.0), (w, -q / 40)
