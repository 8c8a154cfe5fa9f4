"""PNG plots of a static result: the deformed shape over the undeformed reference, and the axial strain and
curvature along each member (StaticResult.along). Uses matplotlib's object API (no pyplot, no global backend)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from . import fields
from .statics import StaticResult


def _save(fig: Figure, path: Path) -> Path:
    FigureCanvasAgg(fig)
    fig.savefig(path, dpi=120)
    return path


def reference(result: StaticResult, member: str, per_element: int = 8) -> dict:
    """Samples of the undeformed reference state (same s as along())."""
    mm = result.assembly.mesh.members[member]
    return fields.sample(mm, mm.x0, per_element)


def plot_shape(result: StaticResult, path: str | Path, per_element: int = 8) -> Path:
    """Deformed shape (solid, nodes marked) and undeformed reference (dashed) of every member."""
    scene = result.assembly.scene
    fig = Figure(figsize=(7, 5), layout="constrained")
    ax = fig.add_subplot(projection="3d" if scene.dim == 3 else None)
    for k, name in enumerate(scene.members):
        color = f"C{k % 10}"
        ref, cur, nodes = reference(result, name, per_element)["r"], result.along(name, per_element)["r"], result.nodes(name)
        ax.plot(*ref.T, ls="--", lw=1, color=color, alpha=0.5)
        ax.plot(*cur.T, lw=2, color=color, label=name)
        ax.plot(*nodes.T, ls="none", marker="o", ms=3, color=color)
    if scene.dim == 2:
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(True, lw=0.3)
    else:
        pts = np.vstack([result.along(n, per_element)["r"] for n in scene.members])
        ax.set_box_aspect(np.maximum(np.ptp(pts, axis=0), 1e-3 * np.ptp(pts, axis=0).max()))
        ax.set_zlabel("z [m]")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(f"{scene.name}: {result.status} (dashed: reference)")
    ax.legend(loc="best", fontsize="small")
    return _save(fig, Path(path))


def plot_fields(result: StaticResult, path: str | Path, per_element: int = 8) -> Path:
    """Axial strain |r_x| - 1 [-] and curvature [1/m] against the material coordinate s [m], per member."""
    scene = result.assembly.scene
    fig = Figure(figsize=(7, 6), layout="constrained")
    ax_e, ax_k = fig.subplots(2, 1, sharex=True)
    for k, name in enumerate(scene.members):
        f = result.along(name, per_element)
        ax_e.plot(f["s"], f["strain"], color=f"C{k % 10}", label=name)
        ax_k.plot(f["s"], f["curvature"], color=f"C{k % 10}", label=name)
    ax_e.set_ylabel("axial strain |r_x| - 1 [-]")
    ax_k.set_ylabel("curvature [1/m]")
    ax_k.set_xlabel("material coordinate s [m]")
    for ax in (ax_e, ax_k):
        ax.grid(True, lw=0.3)
        ax.legend(loc="best", fontsize="small")
    ax_e.set_title(f"{scene.name}: strain and curvature along the members")
    return _save(fig, Path(path))


def write_plots(result: StaticResult, directory: str | Path, per_element: int = 8) -> list[Path]:
    d = Path(directory)
    return [plot_shape(result, d / "shape.png", per_element), plot_fields(result, d / "fields.png", per_element)]
