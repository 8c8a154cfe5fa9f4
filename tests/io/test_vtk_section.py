"""VTK output carries each member's cross-section size as point data (radius, width, thickness), so that ParaView's
Tube filter (Vary Radius: By Absolute Scalar) draws members at their true size.

The values are closed-form functions of the section's input (radius = sqrt(area / pi), width / thickness = b / h):
a round section of diameter d must give radius d/2 to round-off (relative 1e-12: one square root and one division
of numbers near 1e-6), a rectangle its b and h exactly."""
from __future__ import annotations

import meshio
import numpy as np

from ancf_sym import Material, Scene, Section, run_dynamics, solve_static
from ancf_sym.io.dynamics_output import write_series
from ancf_sym.io.vtk import write_vtu

STEEL = Material(E=200e9, density=7800.0)
D, B, H = 0.02, 0.03, 0.01  # rod diameter; bar width and thickness [m]


def frame() -> Scene:
    """A round rod and a rectangular bar hinged at the rod's tip (two members with different sections)."""
    s = Scene(dim=2, gravity=(0.0, -9.81))
    s.member("rod", [(0, 0), (1, 0)], elements=3, material=STEEL, section=Section.circle(D), axial="decoupled")
    s.member("bar", [(1, 0), (1, -0.5)], elements=2, material=STEEL, section=Section.rectangle(B, H),
             axial="decoupled")
    s.clamp("rod", at="start")
    s.hinge(("rod", "end"), ("bar", "start"))
    return s


def check_sections(mesh: meshio.Mesh, per_element: int) -> None:
    member = mesh.point_data["member"]
    assert len(member) == (3 + 2) * per_element + 2
    for key in ("radius", "width", "thickness"):
        assert mesh.point_data[key].shape == member.shape
    rod, bar = member == 0, member == 1
    np.testing.assert_allclose(mesh.point_data["radius"][rod], D / 2, rtol=1e-12)
    np.testing.assert_allclose(mesh.point_data["radius"][bar], np.sqrt(B * H / np.pi), rtol=1e-12)
    assert np.all(mesh.point_data["width"][bar] == B) and np.all(mesh.point_data["thickness"][bar] == H)
    # Section.circle stores its equal-area square: width * thickness is the rod's area
    np.testing.assert_allclose(mesh.point_data["width"][rod] * mesh.point_data["thickness"][rod], np.pi * D**2 / 4,
                               rtol=1e-12)


def test_static_vtu_carries_the_section_size(tmp_path):
    r = solve_static(frame())
    assert r.success
    check_sections(meshio.read(write_vtu(r, tmp_path / "frame.vtu", per_element=4)), 4)


def test_dynamic_series_frames_carry_the_section_size(tmp_path):
    scene = frame()
    r = run_dynamics(scene, {"integrator": "newmark", "dt": 1e-3, "t_end": 3e-3, "output_dt": 1e-3,
                             "record_states": True})
    assert r.success
    write_series(r, tmp_path, per_element=3)
    frames = sorted((tmp_path / "frames").glob("*.vtu"))
    assert len(frames) == len(r.t) >= 2
    for fn in (frames[0], frames[-1]):
        check_sections(meshio.read(fn), 3)
