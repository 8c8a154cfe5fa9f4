"""Files of a modal analysis: result.json (the static result's document, whose keys it keeps, plus the modes), a PNG
of the lowest modes drawn on the equilibrium shape, and the modes as VTK point data on the equilibrium (ParaView:
Warp By Vector with mode_k, animate the scale factor)."""
from __future__ import annotations

from pathlib import Path

import meshio
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ancf_sym.model import fields
from ancf_sym.io.json_out import static_result_dict
from ancf_sym.io.vtk import static_mesh
from ancf_sym.modal.result import ModalResult


def modal_result_dict(result: ModalResult, scene_file: str | Path | None = None, analysis: dict | None = None,
                      wall_total: float | None = None) -> dict:
    """The static result's JSON document (members.NAME.nodes, constraint_forces, ... of the equilibrium) with the
    modal analysis's status and its modes: frequencies [Hz], omega2 [1/s^2], zero (rigid) flags, modal masses [kg]
    and per mode and member the nodal displacements and slope changes (mass-normalised)."""
    doc = static_result_dict(result.static, scene_file, analysis or {"type": "modal"}, wall_total)
    modal = result.to_dict()
    doc["static_status"], doc["static_success"] = doc["status"], doc["success"]
    doc["status"], doc["success"] = result.status, result.success
    doc["wall_s"]["modal"] = result.wall_s
    for key in ("method", "frequencies", "omega2", "omega2_imag", "zero", "modal_masses", "modes", "damped"):
        doc[key] = modal[key]
    doc["mode_normalisation"] = "mass: phi' M phi = 1 (displacements in m per sqrt(kg))"
    return doc


def _mode_positions(result: ModalResult, k: int, name: str, per_element: int) -> np.ndarray:
    """Mode k's displacement at the sample points of fields.sample (linear in the nodal coordinates)."""
    asm = result.static.assembly
    with np.errstate(divide="ignore", invalid="ignore"):  # (its strain and curvature are meaningless for a mode)
        return fields.sample(asm.mesh.members[name], asm.member_coordinates(result.shapes[:, k], name),
                             per_element)["r"]


def _frequency_label(result: ModalResult, k: int) -> str:
    if result.zero[k]:
        return f"mode {k + 1}: 0 Hz (rigid)"
    f = result.frequencies[k]
    return f"mode {k + 1}: {f:.5g} Hz" + (" (unstable)" if f < 0 else "")


def plot_modes(result: ModalResult, path: str | Path, count: int = 6, per_element: int = 8) -> Path:
    """The lowest `count` modes (solid, both signs) on the equilibrium shape (grey), each scaled to a largest
    displacement of 10 % of the structure's size."""
    static = result.static
    scene = static.assembly.scene
    count = min(count, result.modes)
    cols = min(count, 3)
    rows = max(1, -(-count // cols))
    fig = Figure(figsize=(4.2 * cols, 3.4 * rows), layout="constrained")
    eq = {name: static.along(name, per_element)["r"] for name in scene.members}
    pts = np.vstack(list(eq.values()))
    size = float(np.max(np.ptp(pts, axis=0))) or 1.0
    for k in range(count):
        ax = fig.add_subplot(rows, cols, k + 1, projection="3d" if scene.dim == 3 else None)
        u = {name: _mode_positions(result, k, name, per_element) for name in scene.members}
        umax = max(float(np.max(np.linalg.norm(v, axis=1))) for v in u.values())
        a = 0.1 * size / umax if umax > 0 else 0.0
        for j, name in enumerate(scene.members):
            ax.plot(*eq[name].T, color="0.6", lw=1)
            ax.plot(*(eq[name] + a * u[name]).T, color=f"C{j % 10}", lw=1.8)
            ax.plot(*(eq[name] - a * u[name]).T, color=f"C{j % 10}", lw=0.8, ls="--")
        if scene.dim == 2:
            ax.set_aspect("equal", adjustable="datalim")
            ax.grid(True, lw=0.3)
        else:  # a cube around what is drawn (autoscaling would blow a flat direction's round-off up to full size)
            drawn = np.vstack([eq[n] + sg * a * u[n] for n in scene.members for sg in (1, -1)])
            c, h = 0.5 * (drawn.max(axis=0) + drawn.min(axis=0)), 0.5 * float(np.max(np.ptp(drawn, axis=0)))
            ax.set(xlim=(c[0] - h, c[0] + h), ylim=(c[1] - h, c[1] + h), zlim=(c[2] - h, c[2] + h))
            ax.set_box_aspect((1, 1, 1))
        ax.set_title(_frequency_label(result, k) + ("" if a else " (no node moves)"), fontsize="small")
    fig.suptitle(f"{scene.name}: lowest modes on the equilibrium (grey)", fontsize="medium")
    FigureCanvasAgg(fig)
    path = Path(path)
    fig.savefig(path, dpi=110)
    return path


def modes_mesh(result: ModalResult, per_element: int = 8) -> meshio.Mesh:
    """The equilibrium's VTK mesh (ancf_sym.io.vtk.static_mesh) with point data mode_1, mode_2, ... (3 components,
    mass-normalised displacements) at its sample points."""
    mesh = static_mesh(result.static, per_element)
    dim = result.static.assembly.scene.dim
    for k in range(result.modes):
        u = np.vstack([_mode_positions(result, k, name, per_element) for name in result.static.assembly.scene.members])
        v = np.zeros((len(u), 3))
        v[:, :dim] = u
        mesh.point_data[f"mode_{k + 1}"] = v
    return mesh


def write_modes_vtu(result: ModalResult, path: str | Path, per_element: int = 8) -> Path:
    path = Path(path)
    meshio.write(path, modes_mesh(result, per_element), file_format="vtu")
    return path


def animate_modes(result: ModalResult, path: str | Path, count: int = 4, per_element: int = 8,
                  frames_per_mode: int = 24) -> Path:
    """A GIF of the lowest `count` modes, one period each, on the equilibrium shape (dashed), each scaled to a
    largest displacement of 10 % of the structure's size as in plot_modes (plots.animate_shapes draws it)."""
    from ancf_sym.io.plots import animate_shapes, oscillation

    static = result.static
    scene = static.assembly.scene
    eq = {name: static.along(name, per_element)["r"] for name in scene.members}
    size = float(np.max(np.ptp(np.vstack(list(eq.values())), axis=0))) or 1.0
    frames, captions = [], []
    for k in range(min(count, result.modes)):
        u = {name: _mode_positions(result, k, name, per_element) for name in scene.members}
        umax = max(float(np.max(np.linalg.norm(v, axis=1))) for v in u.values())
        a = 0.1 * size / umax if umax > 0 else 0.0
        frames += oscillation(eq, u, a, frames_per_mode)
        captions += [_frequency_label(result, k)] * frames_per_mode
    return animate_shapes(frames, path, captions=captions, reference=eq,
                          title=f"{scene.name}: lowest modes on the equilibrium (dashed)", fps=frames_per_mode)
