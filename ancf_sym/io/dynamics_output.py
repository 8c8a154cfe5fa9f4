"""Outputs of a dynamic run for the CLI: result.json, PNG time histories, a VTK time series (.pvd + one .vtu per
output time) for ParaView, and an animation (motion.gif) of the members' motion.

The frames need every coordinate at the output times: the run records them as states (DynamicOptions.record_states,
which the command line sets; DynamicResult.states).
"""
from __future__ import annotations

import math
from pathlib import Path
from xml.sax.saxutils import quoteattr

import meshio
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ancf_sym.contact import summary as contact
from ancf_sym.model import fields
from ancf_sym.io.json_out import json_ready, write_json
from ancf_sym.io.vtk import samples_per_element, section_point_data, write_mesh

def _full_states(result) -> list[np.ndarray]:
    """Full coordinate vectors at the output times (DynamicResult.states; the final state only without them)."""
    if not len(result.t) or result.states is None:
        return [np.asarray(result.x)]
    return list(result.states)


def _states(result) -> np.ndarray:
    """(n_outputs, n) coordinates at the output times; refused before any file is written without them."""
    if result.states is None:
        raise ValueError("the VTK series and the animation need every coordinate at the output times: run the "
                         "dynamics with DynamicOptions(record_states=True) (the command line does)")
    return result.states


def _deepest(t, recs: list[dict]) -> dict:
    """The smallest true gap over the output times, when and where (contact.gap.Closest.record per time)."""
    gaps = [r["smallest_gap"] if r["smallest_gap"] is not None else math.inf for r in recs]
    k = int(np.argmin(gaps))
    r = recs[k]
    return {"smallest_gap_min": {"gap": r["smallest_gap"], "t": float(t[k]) if len(t) > k else None,
                                 "element": r["element"], "xi": r["xi"], "s": r["s"],
                                 "sampled_penetration": r["sampled_penetration"]},
            "hidden_penetration": any(r["hidden_penetration"] for r in recs)}


def result_dict(result, scene_file, analysis: dict, wall_total: float) -> dict:
    d = result.to_dict()
    scene = result.assembly.scene
    if scene.contacts:  # per penalty contact, at the output times: min_gap, smallest_gap [m], normal_force [N]
        reps = [contact.report(result.assembly, x) for x in _full_states(result)]
        ts = list(result.t) if len(reps) == len(result.t) else list(result.t[-1:])  # (no frames: the final state)
        d["contacts"] = [{"type": reps[0][i]["type"], "member": reps[0][i]["member"],
                          **{k: [r[i][k] for r in reps] for k in ("min_gap", "normal_force", "smallest_gap")},
                          **_deepest(ts, [r[i] for r in reps])} for i in range(len(reps[0]))] \
            if reps and reps[0] else []
    return json_ready({"format": "ancf_sym.dynamics/1", "scene": {"name": scene.name, "file": str(Path(scene_file).resolve()),
                                                               "dim": scene.dim},
                   "analysis": analysis, "wall_total_s": wall_total, **d})


def sensor_panels(sensor, dim: int, node_size: int) -> list[tuple[str, list[tuple[int, str]]]]:
    """How a sensor is drawn: one panel per quantity, (y label with its unit, [(column, component name)])."""
    axes = "xyz"[:dim]

    def vec(first: int = 0) -> list[tuple[int, str]]:
        return [(first + i, a) for i, a in enumerate(axes)]

    n, k = sensor.name, sensor.kind
    if k in ("position", "displacement", "velocity"):
        return [(f"{n}: {k} [{'m/s' if k == 'velocity' else 'm'}]", vec())]
    if k == "strain":
        return [(f"{n}: stretch |r_x| - 1 [-]", [(0, "")])]
    if k == "curvature":
        return [(f"{n}: curvature [1/m]", [(0, "")])]
    if k == "coordinates":  # a node's r, r_x (beam3d: r_y, r_z too)
        slopes = [("r_x", dim)] + ([("r_y", 2 * dim), ("r_z", 3 * dim)] if node_size == 4 * dim else [])
        return [(f"{n}: node position [m]", vec())] + [(f"{n}: slope {s} [-]", vec(c)) for s, c in slopes]
    if k == "body" and dim == 2:
        return [(f"{n}: centre of mass [m]", vec()), (f"{n}: angle [rad]", [(2, "")]),
                (f"{n}: angular velocity [rad/s]", [(3, "")])]
    if k == "body":
        return [(f"{n}: centre of mass [m]", vec()), (f"{n}: angular velocity [rad/s]", vec(3)),
                (f"{n}: body axes [-]", [(6 + 3 * e + i, f"e{e + 1} {a}") for e in range(3) for i, a in enumerate(axes)])]
    return [(n, [])]


ENERGY_NAMES = {"kinetic": "kinetic", "potential": "potential (all)", "total": "total (kinetic + potential)",
                "damping_work": "damping work", "external_work": "work of time loads"}
ZERO_ENERGY = 1e-12  # a term whose largest |value| is below this fraction of the largest term's: round-off, not drawn


def energy_terms(energies: dict) -> tuple[dict, list[str]]:
    """(label -> values of the terms worth drawing, names of the terms left out as zero throughout): terms below
    ZERO_ENERGY of the largest, the potential sum when one potential term is all of it, and `algorithmic` (drawn
    in its own panel) are left out."""
    arr = {k: np.asarray(v, float) for k, v in energies.items()}
    scale = max((float(np.max(np.abs(v))) for v in arr.values() if v.size), default=0.0)
    zero = [k for k, v in arr.items() if not v.size or float(np.max(np.abs(v))) <= ZERO_ENERGY * scale]
    parts = [k for k in arr if k.startswith("potential_") and k not in zero]
    keep = {}
    for k, v in arr.items():
        if k in zero or k == "algorithmic" or (k == "potential" and len(parts) == 1):
            continue
        keep[ENERGY_NAMES.get(k, k.removeprefix("potential_") + " potential")] = v
    return keep, zero


def plot_histories(result, path: Path) -> Path:
    """history_figure saved as a PNG."""
    fig = history_figure(result)
    FigureCanvasAgg(fig)
    fig.savefig(path, dpi=110)
    return path


def history_figure(result) -> Figure:
    """One panel per sensor quantity (its unit and component names on the axis and in the legend), the energies
    that are not zero throughout, and the energy the integrator removed (if any); legends beside the data."""
    asm = result.assembly
    dim = asm.scene.dim
    sensors = {s.name: s for s in (result.options.sensors if result.options else [])}
    panels = []
    for name, v in result.sensors.items():
        v = np.asarray(v).reshape(len(result.t), -1)
        s = sensors.get(name)
        if s is None:  # (a result without its options: columns as they are)
            spec = [(name, [(k, f"[{k}]") for k in range(v.shape[1])])]
        else:
            ns = asm.mesh.members[s.member].node_size if s.kind == "coordinates" else 0
            spec = sensor_panels(s, dim, ns)
        panels += [(label, [(v[:, c], comp) for c, comp in comps if c < v.shape[1]]) for label, comps in spec]
    terms, zero = energy_terms(result.energies)
    alg = np.asarray(result.energies.get("algorithmic", []), float)
    show_alg = "algorithmic" not in zero and alg.size
    n = len(panels) + 1 + bool(show_alg)
    fig = Figure(figsize=(9, 1.2 + 2.1 * n), layout="constrained")
    axes = fig.subplots(n, 1, sharex=True, squeeze=False)[:, 0]
    for ax, (label, curves) in zip(axes, panels):
        for values, comp in curves:
            ax.plot(result.t, values, label=comp or None)
        ax.set_ylabel(label, fontsize="small")
        if len(curves) > 1:
            ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1), fontsize="small")
    ax = axes[len(panels)]
    for label, v in terms.items():
        ax.plot(result.t, v, label=label)
    ax.set_ylabel("energy [J]")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1), fontsize="small",
              title="zero throughout:\n" + ", ".join(z.removeprefix("potential_") for z in zero) if zero else None,
              title_fontsize="x-small")
    if show_alg:
        axes[-1].plot(result.t, alg, color="0.3")
        axes[-1].set_ylabel("removed by the\nintegrator [J]", fontsize="small")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.ticklabel_format(axis="y", style="sci", scilimits=(-3, 4))
    axes[-1].set_xlabel("time t [s]")
    axes[0].set_title(f"{asm.scene.name}: {result.integrator}, {result.status} at t = {result.t_reached:.4g} s")
    return fig


def write_animation(result, path: Path, per_element: int = 8) -> Path:
    """motion.gif: the members' shapes at the output times (at most plots.MAX_FRAMES, evenly chosen, the last
    included), over the reference (dashed), with supports, grounds and fixed drums; about real time, 4-25 frames/s."""
    from ancf_sym.io.plots import MAX_FRAMES, SUPPORT_STYLE, animate_shapes, draw_contacts, member_shapes

    asm = result.assembly
    t = np.asarray(result.t, float)
    pick = np.unique(np.r_[np.linspace(0, len(t) - 1, min(len(t), MAX_FRAMES)).round().astype(int), len(t) - 1])
    states = _states(result)
    frames = [member_shapes(asm, states[k], per_element) for k in pick]
    span = float(t[pick[-1]] - t[pick[0]])
    fps = float(np.clip(len(pick) / span, 4, 25)) if span > 0 else 10.0
    scene = asm.scene

    def decorate(ax) -> None:
        from ancf_sym.model.mesh import Probe
        for s in scene.supports:
            mm = asm.mesh.members[s.member]
            p = Probe(mm, mm.coordinate(s.at), scene.dim).r(asm.x0)
            ax.plot(*[[c] for c in p], ls="none", zorder=5, **SUPPORT_STYLE.get(s.kind, {}))
        draw_contacts(ax, scene, {}, moving=False)

    return animate_shapes(frames, path, captions=[f"t = {t[k]:.3f} s" for k in pick],
                          reference=member_shapes(asm, asm.x0, per_element), title=scene.name, fps=fps,
                          decorate=decorate)


def write_series(result, directory: Path, per_element: int = 8) -> Path:
    """frames/frame_XXXX.vtu per output time and series.pvd listing them with their times."""
    all_states = _states(result)
    frames = directory / "frames"
    frames.mkdir()
    members = result.assembly.mesh.members
    states = {name: all_states[:, mm.offset:mm.offset + mm.x0.size].reshape(len(all_states), mm.n_nodes, -1)
              for name, mm in members.items()}
    entries = []
    section_data = section_point_data(result.assembly.mesh, per_element)
    full = all_states if result.assembly.scene.contacts else None
    for k, t in enumerate(result.t):
        pts, cells, s_all, strain, axial, curv, member = [], [], [], [], [], [], []
        n0 = 0
        for m, (name, X) in enumerate(states.items()):
            f = fields.sample(result.assembly.mesh.members[name], X[k], per_element)
            r = np.zeros((len(f["s"]), 3))
            r[:, :f["r"].shape[1]] = f["r"]
            pts.append(r)
            idx = n0 + np.arange(len(r))
            cells.append(("line", np.c_[idx[:-1], idx[1:]]))
            s_all.append(f["s"]); strain.append(f["strain"]); axial.append(f["axial_strain"])
            curv.append(f["curvature"])
            member.append(np.full(len(r), m, dtype=np.int32))
            n0 += len(r)
        mesh = meshio.Mesh(np.vstack(pts), cells, point_data={
            "s": np.concatenate(s_all), "strain": np.concatenate(strain), "axial_strain": np.concatenate(axial),
            "curvature": np.concatenate(curv),
            "member": np.concatenate(member), **section_data,
            **(contact.point_data(result.assembly, full[k], per_element) if full is not None else {})})
        fn = frames / f"frame_{k:05d}.vtu"
        write_mesh(fn, mesh)
        entries.append(f'    <DataSet timestep={quoteattr(repr(float(t)))} part="0" file="frames/{fn.name}"/>')
    pvd = directory / "series.pvd"
    pvd.write_text('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n  <Collection>\n'
                   + "\n".join(entries) + "\n  </Collection>\n</VTKFile>\n")
    return pvd


def write_outputs(result, scene_file, analysis: dict, out: Path, wall_total: float, per_element: int | None = 8,
                  animation: bool = True) -> None:
    """result.json, history.png, the VTK series and (animation) motion.gif; per_element None: as many samples per
    element as io.vtk.samples_per_element gives the mesh."""
    write_json(out / "result.json", result_dict(result, scene_file, analysis, wall_total), clean=False)
    per_element = samples_per_element(result.assembly.mesh, per_element)
    if len(result.t):
        plot_histories(result, out / "history.png")
        write_series(result, out, per_element)
        if animation and len(result.t) > 1:
            write_animation(result, out / "motion.gif", per_element)
