"""VTK (.vtu, via meshio) of a static result for ParaView.

Points: every member sampled along its deformed centreline (StaticResult.along, per_element samples per element),
in 3D (z = 0 for planar scenes). Cells: one block of 2-point line cells per member, chained in order (meshio has
no poly-line type; ParaView draws the chain as the member's curve). Point data: s [m] (material coordinate),
strain [-] (|r_x| - 1), axial_strain [-] (the measure the member's axial energy uses: ancf_sym.model.fields.axial_measure;
for the decoupled strain the equivalent rod's), curvature [1/m], displacement [m] (from the reference; "Warp By Vector" with factor -1
shows the undeformed state), member (index in scene order), and the cross-section's size (section_size): radius,
width, thickness [m]. Cell data: member.

Members at their true size in ParaView: select the .vtu (or the dynamics series.pvd), add the Tube filter, set
Scalars = radius and Vary Radius = By Absolute Scalar (Radius Factor is then ignored); Number of Sides 4 draws an
equal-area square tube.
"""
from __future__ import annotations

from pathlib import Path

import meshio
import numpy as np

from ancf_sym.contact import summary as contact
from ancf_sym.model import fields
from ancf_sym.model.mesh import Mesh
from ancf_sym.scene.builder import Member
from ancf_sym.statics.problem import StaticResult


DEFAULT_SAMPLES = 8  # samples per element of the VTK files and plots when none are asked for
VTK_POINTS = 200_000  # ... fewer (at least the nodes) where the scene's elements would give more points than this


def samples_per_element(mesh: Mesh, samples: int | None) -> int:
    """The samples per element to write: `samples` if given, else DEFAULT_SAMPLES, fewer on large meshes (at least
    1: the nodes) so that a file has about VTK_POINTS points at most: its writing stays proportional to the model,
    not to the mesh times a resolution no screen shows."""
    if samples is not None:
        return samples
    n = sum(len(mm.elem_nodes) for mm in mesh.members.values())
    return max(1, min(DEFAULT_SAMPLES, VTK_POINTS // max(n, 1)))


def section_size(member: Member, n: int) -> dict[str, np.ndarray]:
    """Point data of a member's cross-section at its n sample points [m]: radius = sqrt(area / pi), the radius of the
    round section of the same area (exact for a circle), which ParaView's Tube filter takes as an absolute radius;
    width and thickness = the section's b and h where it gives them (Section.rectangle, beam3d sections;
    Section.circle gives its equal-area square), else the round section's diameter."""
    sec = member.section
    radius = float(np.sqrt(sec.area / np.pi))
    width = sec.b if sec.b is not None else 2 * radius
    thickness = sec.h if sec.h is not None else 2 * radius
    return {"radius": np.full(n, radius), "width": np.full(n, float(width)), "thickness": np.full(n, float(thickness))}


def section_point_data(mesh: Mesh, per_element: int = 8) -> dict[str, np.ndarray]:
    """section_size of every member at the points fields.sample gives (per_element per element, shared ends once),
    members in mesh order: the same in every frame of a time series."""
    parts = [section_size(mm.member, len(mm.elem_nodes) * per_element + 1) for mm in mesh.members.values()]
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


def static_mesh(result: StaticResult, per_element: int = 8) -> meshio.Mesh:
    keys = ("s", "strain", "axial_strain", "curvature", "displacement", "member")
    pts, cells, data, cell_member = [], [], {k: [] for k in keys}, []
    n0 = 0
    for k, name in enumerate(result.assembly.scene.members):
        mm = result.assembly.mesh.members[name]
        f, ref = result.along(name, per_element), fields.positions(mm, mm.x0, per_element)
        r = np.zeros((len(f["s"]), 3))
        r[:, :f["r"].shape[1]] = f["r"]
        u = np.zeros_like(r)
        u[:, :f["r"].shape[1]] = f["r"] - ref
        pts.append(r)
        idx = n0 + np.arange(len(r))
        cells.append(("line", np.c_[idx[:-1], idx[1:]]))
        cell_member.append(np.full(len(r) - 1, k))
        for key, v in (("s", f["s"]), ("strain", f["strain"]), ("axial_strain", f["axial_strain"]),
                       ("curvature", f["curvature"]), ("displacement", u),
                       ("member", np.full(len(r), k))):
            data[key].append(v)
        n0 += len(r)
    point_data = {k: np.concatenate(v) for k, v in data.items()}
    point_data["member"] = point_data["member"].astype(np.int32)
    point_data.update(section_point_data(result.assembly.mesh, per_element))
    point_data.update(contact.point_data(result.assembly, result.x, per_element,
                                         result.constraint_forces.get("contact")))
    return meshio.Mesh(np.vstack(pts), cells, point_data=point_data,
                       cell_data={"member": [c.astype(np.int32) for c in cell_member]})


COMPRESS_POINTS = 50_000  # zlib-compressed up to this many points; beyond, compressing costs more than a solve


def write_mesh(path: str | Path, mesh: meshio.Mesh) -> Path:
    """A .vtu (binary; zlib-compressed when small: at 150 000 points compression took ~1 s, a third of the solve)."""
    path = Path(path)
    meshio.vtu.write(path, mesh, binary=True, compression="zlib" if len(mesh.points) <= COMPRESS_POINTS else None)
    return path


def write_vtu(result: StaticResult, path: str | Path, per_element: int = 8) -> Path:
    return write_mesh(path, static_mesh(result, per_element))
