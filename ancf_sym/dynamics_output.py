"""Outputs of a dynamic run for the CLI: result.json, PNG time histories, a VTK time series (.pvd + one .vtu per
output time) for ParaView.

The frames need every node's coordinates at the output times: the CLI adds one "coordinates" sensor per public
node (named with a leading "__", left out of result.json and the plots). A polyline vertex's hidden duplicate
node takes its public twin's coordinates (same position; the slope of the segment before the vertex).
"""
from __future__ import annotations

import math
from pathlib import Path
from xml.sax.saxutils import quoteattr

import meshio
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from . import contact, fields
from .output_json import _clean, write_json
from .vtk_out import section_point_data

FRAME_PREFIX = "__node"


def frame_sensors(scene) -> list[dict]:
    """One coordinates sensor per public node of every member."""
    from .mesh import build_mesh

    out = []
    for name, mm in build_mesh(scene).members.items():
        out += [{"name": f"{FRAME_PREFIX}:{name}:{j}", "kind": "coordinates", "member": name, "at": j}
                for j in range(len(mm.public_nodes))]
    return out


def _member_states(result, name: str) -> np.ndarray:
    """(n_times, n_internal_nodes, node_size) coordinates of a member at the output times."""
    mm = result.assembly.mesh.members[name]
    public = {int(i): j for j, i in enumerate(mm.public_nodes)}
    rows = []
    for i in range(mm.n_nodes):
        j = public.get(i, public.get(i - 1))
        rows.append(np.asarray(result.sensors[f"{FRAME_PREFIX}:{name}:{j}"]))
    return np.stack(rows, axis=1)


def _full_states(result) -> list[np.ndarray]:
    """Full coordinate vectors at the output times, from the frame sensors (final state only without them)."""
    mesh = result.assembly.mesh
    if not len(result.t) or not any(k.startswith(FRAME_PREFIX) for k in result.sensors):
        return [np.asarray(result.x)]
    states = {name: _member_states(result, name) for name in mesh.members}
    out = []
    for k in range(len(result.t)):
        x = np.array(result.x, float)
        for name, X in states.items():
            mm = mesh.members[name]
            x[mm.offset:mm.offset + mm.x0.size] = X[k].ravel()
        out.append(x)
    return out


def _deepest(t, recs: list[dict]) -> dict:
    """The smallest true gap over the output times, when and where (contact_gap.Closest.record per time)."""
    gaps = [r["smallest_gap"] if r["smallest_gap"] is not None else math.inf for r in recs]
    k = int(np.argmin(gaps))
    r = recs[k]
    return {"smallest_gap_min": {"gap": r["smallest_gap"], "t": float(t[k]) if len(t) > k else None,
                                 "element": r["element"], "xi": r["xi"], "s": r["s"],
                                 "sampled_penetration": r["sampled_penetration"]},
            "hidden_penetration": any(r["hidden_penetration"] for r in recs)}


def result_dict(result, scene_file, analysis: dict, wall_total: float) -> dict:
    d = result.to_dict()
    d["sensors"] = {k: v for k, v in d["sensors"].items() if not k.startswith(FRAME_PREFIX)}
    scene = result.assembly.scene
    if scene.contacts:  # per penalty contact, at the output times: min_gap, smallest_gap [m], normal_force [N]
        reps = [contact.report(result.assembly, x) for x in _full_states(result)]
        ts = list(result.t) if len(reps) == len(result.t) else list(result.t[-1:])  # (no frames: the final state)
        d["contacts"] = [{"type": reps[0][i]["type"], "member": reps[0][i]["member"],
                          **{k: [r[i][k] for r in reps] for k in ("min_gap", "normal_force", "smallest_gap")},
                          **_deepest(ts, [r[i] for r in reps])} for i in range(len(reps[0]))] \
            if reps and reps[0] else []
    return _clean({"format": "ancf_sym.dynamics/1", "scene": {"name": scene.name, "file": str(Path(scene_file).resolve()),
                                                               "dim": scene.dim},
                   "analysis": analysis, "wall_total_s": wall_total, **d})


def plot_histories(result, path: Path) -> Path:
    user = {k: np.asarray(v) for k, v in result.sensors.items() if not k.startswith(FRAME_PREFIX)}
    n = len(user) + 1
    fig = Figure(figsize=(8, 2.6 * n), layout="constrained")
    axes = fig.subplots(n, 1, sharex=True, squeeze=False)[:, 0]
    for ax, (name, v) in zip(axes, user.items()):
        v = v.reshape(len(result.t), -1)
        for k in range(v.shape[1]):
            ax.plot(result.t, v[:, k], label=f"{name}[{k}]" if v.shape[1] > 1 else name)
        ax.set_ylabel(name)
        ax.legend(loc="best", fontsize=8)
        ax.grid(alpha=0.3)
    ax = axes[-1]
    for name, e in result.energies.items():
        ax.plot(result.t, e, label=name)
    ax.set_ylabel("energy [J]")
    ax.set_xlabel("t [s]")
    ax.legend(loc="best", fontsize=8, ncol=3)
    ax.grid(alpha=0.3)
    FigureCanvasAgg(fig)
    fig.savefig(path, dpi=110)
    return path


def write_series(result, directory: Path, per_element: int = 8) -> Path:
    """frames/frame_XXXX.vtu per output time and series.pvd listing them with their times."""
    frames = directory / "frames"
    frames.mkdir()
    states = {name: _member_states(result, name) for name in result.assembly.mesh.members}
    entries = []
    section_data = section_point_data(result.assembly.mesh, per_element)
    full = _full_states(result) if result.assembly.scene.contacts else None
    for k, t in enumerate(result.t):
        pts, cells, s_all, strain, curv, member = [], [], [], [], [], []
        n0 = 0
        for m, (name, X) in enumerate(states.items()):
            f = fields.sample(result.assembly.mesh.members[name], X[k], per_element)
            r = np.zeros((len(f["s"]), 3))
            r[:, :f["r"].shape[1]] = f["r"]
            pts.append(r)
            idx = n0 + np.arange(len(r))
            cells.append(("line", np.c_[idx[:-1], idx[1:]]))
            s_all.append(f["s"]); strain.append(f["strain"]); curv.append(f["curvature"])
            member.append(np.full(len(r), m, dtype=np.int32))
            n0 += len(r)
        mesh = meshio.Mesh(np.vstack(pts), cells, point_data={
            "s": np.concatenate(s_all), "strain": np.concatenate(strain), "curvature": np.concatenate(curv),
            "member": np.concatenate(member), **section_data,
            **(contact.point_data(result.assembly, full[k], per_element) if full else {})})
        fn = frames / f"frame_{k:05d}.vtu"
        meshio.write(fn, mesh, file_format="vtu")
        entries.append(f'    <DataSet timestep={quoteattr(repr(float(t)))} part="0" file="frames/{fn.name}"/>')
    pvd = directory / "series.pvd"
    pvd.write_text('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n  <Collection>\n'
                   + "\n".join(entries) + "\n  </Collection>\n</VTKFile>\n")
    return pvd


def write_outputs(result, scene_file, analysis: dict, out: Path, wall_total: float, per_element: int = 8) -> None:
    write_json(out / "result.json", result_dict(result, scene_file, analysis, wall_total))
    if len(result.t):
        plot_histories(result, out / "history.png")
        write_series(result, out, per_element)
