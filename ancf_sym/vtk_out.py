"""VTK (.vtu, via meshio) of a static result for ParaView.

Points: every member sampled along its deformed centreline (StaticResult.along, per_element samples per element),
in 3D (z = 0 for planar scenes). Cells: one block of 2-point line cells per member, chained in order (meshio has
no poly-line type; ParaView draws the chain as the member's curve). Point data: s [m] (material coordinate),
strain [-] (|r_x| - 1), curvature [1/m], displacement [m] (from the reference; "Warp By Vector" with factor -1
shows the undeformed state), member (index in scene order). Cell data: member.
"""
from __future__ import annotations

from pathlib import Path

import meshio
import numpy as np

from .plots import reference
from .statics import StaticResult


def static_mesh(result: StaticResult, per_element: int = 8) -> meshio.Mesh:
    pts, cells, data, cell_member = [], [], {k: [] for k in ("s", "strain", "curvature", "displacement", "member")}, []
    n0 = 0
    for k, name in enumerate(result.assembly.scene.members):
        f, ref = result.along(name, per_element), reference(result, name, per_element)
        r = np.zeros((len(f["s"]), 3))
        r[:, :f["r"].shape[1]] = f["r"]
        u = np.zeros_like(r)
        u[:, :f["r"].shape[1]] = f["r"] - ref["r"]
        pts.append(r)
        idx = n0 + np.arange(len(r))
        cells.append(("line", np.c_[idx[:-1], idx[1:]]))
        cell_member.append(np.full(len(r) - 1, k))
        for key, v in (("s", f["s"]), ("strain", f["strain"]), ("curvature", f["curvature"]), ("displacement", u),
                       ("member", np.full(len(r), k))):
            data[key].append(v)
        n0 += len(r)
    point_data = {k: np.concatenate(v) for k, v in data.items()}
    point_data["member"] = point_data["member"].astype(np.int32)
    return meshio.Mesh(np.vstack(pts), cells, point_data=point_data,
                       cell_data={"member": [c.astype(np.int32) for c in cell_member]})


def write_vtu(result: StaticResult, path: str | Path, per_element: int = 8) -> Path:
    path = Path(path)
    meshio.write(path, static_mesh(result, per_element), file_format="vtu")
    return path
