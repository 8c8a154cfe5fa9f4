"""PNG plots of a static result, read at a glance: the deformed shape over the undeformed reference (magnified, with
the factor stated, where the deflection is too small to see), with its supports, joints, contacts and loads drawn;
the axial strain (the measure each member's energy uses, named on the axis) and the curvature along each member.
Also the shape drawing of an animation (`animate_shapes`, used for dynamics runs by ancf_sym.io.dynamics_output and
offered for mode shapes). Uses matplotlib's object API (no pyplot, no global backend).

The curves are decimated to screen resolution (`MAX_POINTS` per curve; a field keeps each bin's minimum and
maximum, so an oscillation from element to element stays visible): a 150 000-element result plots as fast as a
small one.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Callable, Sequence

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ancf_sym.model import fields
from ancf_sym.model.mesh import Probe
from ancf_sym.statics.problem import StaticResult

MAX_POINTS = 2000  # points per curve: a few per pixel column of the saved figures
ENVELOPE_POINTS = 200_000  # samples a field's envelope is taken from (per member; at least 2 per element)
SMALL_DEFLECTION = 0.05  # max displacement below this fraction of the structure's size: the shape is magnified
SHOWN_DEFLECTION = 0.15  # ... so that it is drawn as about this fraction (a 1-2-5 factor)


def _save(fig: Figure, path: Path) -> Path:
    FigureCanvasAgg(fig)
    fig.savefig(path, dpi=120)
    return path


def plot_per_element(n_elements: int, per_element: int) -> int:
    """Samples per element for a curve of a member of n_elements: per_element, fewer on long meshes (at least the
    nodes) so that a curve has about MAX_POINTS points."""
    return max(1, min(per_element, math.ceil(MAX_POINTS / max(n_elements, 1))))


def reference(result: StaticResult, member: str, per_element: int = 8) -> dict:
    """Samples of the undeformed reference state (same s as along())."""
    mm = result.assembly.mesh.members[member]
    return fields.sample(mm, mm.x0, per_element)


def member_shapes(assembly, x: np.ndarray, per_element: int = 8) -> dict[str, np.ndarray]:
    """member name -> (k, dim) centre-line points of coordinates x (decimated to MAX_POINTS per member): the frames
    animate_shapes draws."""
    out = {}
    for name, mm in assembly.mesh.members.items():
        pe = plot_per_element(len(mm.elem_nodes), per_element)
        out[name] = _decimate(fields.positions(mm, assembly.member_coordinates(x, name), pe))
    return out


def _decimate(r: np.ndarray, n: int = MAX_POINTS) -> np.ndarray:
    """Every k-th row (the last kept) so that at most about n remain: a smooth curve at screen resolution."""
    if len(r) <= n:
        return r
    idx = np.unique(np.r_[np.arange(0, len(r), math.ceil(len(r) / n)), len(r) - 1])
    return r[idx]


def envelope(s: np.ndarray, v: np.ndarray, bins: int = MAX_POINTS // 2) -> tuple[np.ndarray, np.ndarray]:
    """(s, v) reduced to each of `bins` equal s-bins' minimum and maximum, in s order: the line drawn through them
    covers every value an undecimated line would (oscillations included) with 2 points per bin."""
    if len(s) <= 2 * bins:
        return s, v
    edges = np.linspace(s[0], s[-1], bins + 1)
    b = np.clip(np.searchsorted(edges, s, side="right") - 1, 0, bins - 1)
    starts = np.r_[0, np.flatnonzero(np.diff(b)) + 1]
    lo, hi = np.minimum.reduceat(v, starts), np.maximum.reduceat(v, starts)
    ends = np.r_[starts[1:], len(s)]
    sb = (s[starts] + s[ends - 1]) / 2
    return np.repeat(sb, 2), np.column_stack([lo, hi]).ravel()


def nice_factor(value: float) -> float:
    """The largest 1, 2 or 5 x 10^k not above value (value >= 1)."""
    k = math.floor(math.log10(value))
    for m in (5, 2, 1):
        if m * 10.0**k <= value:
            return m * 10.0**k
    return 10.0**k


def magnification(reference: Sequence[np.ndarray], deformed: Sequence[np.ndarray]) -> tuple[float, float, float]:
    """(factor, max displacement [m], structure size [m]): factor 1 unless the largest displacement is below
    SMALL_DEFLECTION of the size (the largest extent of the reference), then a 1-2-5 factor drawing it as about
    SHOWN_DEFLECTION of the size."""
    ref, cur = np.vstack(reference), np.vstack(deformed)
    size = float(np.ptp(ref, axis=0).max()) if len(ref) > 1 else 0.0
    dmax = float(np.linalg.norm(cur - ref, axis=1).max()) if len(ref) else 0.0
    if size <= 0 or dmax <= 1e-12 * size or dmax >= SMALL_DEFLECTION * size:
        return 1.0, dmax, size
    return nice_factor(SHOWN_DEFLECTION * size / dmax), dmax, size


def length_text(v: float) -> str:
    """A length with a unit a reader takes in: 11.9 mm, 0.473 m, 2.1 um."""
    a = abs(v)
    if a >= 0.1 or a == 0:
        return f"{v:.3g} m"
    if a >= 1e-4:
        return f"{v * 1e3:.3g} mm"
    return f"{v * 1e6:.3g} um"


class _View:
    """Positions as drawn: reference + factor (deformed - reference)."""

    def __init__(self, result: StaticResult, factor: float):
        self.asm, self.x, self.factor = result.assembly, np.asarray(result.x), factor

    def point(self, member: str, at) -> np.ndarray:
        mm = self.asm.mesh.members[member]
        p = Probe(mm, mm.coordinate(at), self.asm.scene.dim)
        r0 = p.r(self.asm.x0)
        return r0 + self.factor * (p.r(self.x) - r0)

    def tangent(self, member: str, at) -> np.ndarray:
        mm = self.asm.mesh.members[member]
        t = Probe(mm, mm.coordinate(at), self.asm.scene.dim).rx(self.x)
        return t / max(np.linalg.norm(t), 1e-300)


SUPPORT_STYLE = {"clamp": dict(marker="s", ms=10, mfc="k", mec="k"), "pin": dict(marker="^", ms=10, mfc="k", mec="k"),
                 "slope": dict(marker="D", ms=8, mfc="w", mec="k")}
JOINT_STYLE = {"hinge": dict(marker="o", ms=9, mfc="w", mec="k", mew=1.5),
               "rigid": dict(marker="D", ms=8, mfc="0.5", mec="k")}
LOAD_COLOR = "crimson"


def _mark(ax, p: np.ndarray, label: str, seen: set, **style) -> None:
    """A marker at p, its label in the legend once."""
    ax.plot(*[[c] for c in p], ls="none", zorder=5, label=None if label in seen else label, **style)
    seen.add(label)


def _arrow(ax, tip: np.ndarray, direction: np.ndarray, length: float, text: str | None) -> None:
    """An arrow of `length` pointing along direction and ending at tip (a load applied there)."""
    d = direction / max(np.linalg.norm(direction), 1e-300) * length
    if len(tip) == 3:
        ax.quiver(*(tip - d), *d, color=LOAD_COLOR, lw=1.5, arrow_length_ratio=0.25)
        if text:
            ax.text(*(tip - d), text, color=LOAD_COLOR, fontsize=8)
        return
    ax.annotate("", xy=tip, xytext=tip - d, arrowprops=dict(arrowstyle="-|>", color=LOAD_COLOR, lw=1.5),
                zorder=6)
    if text:
        ax.annotate(text, xy=tip - d, color=LOAD_COLOR, fontsize=8, ha="center",
                    va="bottom" if d[1] <= 0 else "top", xytext=(0, 3 if d[1] <= 0 else -3),
                    textcoords="offset points")


def _vec_text(v, unit: str) -> str:
    """A load's size: a scalar's value, a vector's magnitude (the arrow shows its direction)."""
    v = np.atleast_1d(np.asarray(v, float))
    return f"{v[0]:.3g} {unit}" if len(v) == 1 else f"{float(np.linalg.norm(v)):.3g} {unit}"


def draw_supports(ax, result: StaticResult, view: _View) -> None:
    """Supports, joints, rigid bodies and contacts (ground, drums), in the legend by kind."""
    scene = result.assembly.scene
    seen: set = set()
    for s in scene.supports:
        _mark(ax, view.point(s.member, s.at), f"{s.kind} support", seen, **SUPPORT_STYLE.get(s.kind, {}))
    for j in scene.joints:
        _mark(ax, view.point(*j.a), f"{j.kind} joint", seen, **JOINT_STYLE.get(j.kind, {}))
    for name in scene.bodies:
        p = np.asarray(result.body(name)[:scene.dim] if scene.dim == 2 else result.body(name)[0], float)
        p0 = np.asarray(scene.bodies[name].position, float)
        _mark(ax, p0 + view.factor * (p - p0), "rigid body", seen, marker="o", ms=12, mfc="0.7", mec="k")
    draw_contacts(ax, scene, {name: np.asarray(result.body(name)[:2]) for name in scene.bodies}
                  if scene.dim == 2 else {})


def draw_contacts(ax, scene, body_positions: dict, moving: bool = True) -> None:
    """Grounds as lines, drums as circles (planar scenes; a body's drum at its position in body_positions, left out
    when not moving: an animation's fixed decoration)."""
    from matplotlib.patches import Circle

    from ancf_sym.contact.laws import DrumContact, GroundContact

    for k, c in enumerate(scene.contacts):
        first = k == 0 or type(scene.contacts[k - 1]) is not type(c)
        if scene.dim != 2:
            continue
        if isinstance(c, GroundContact):
            n = np.asarray(c.normal, float)
            p0 = c.level * n / (n @ n)
            ax.axline(p0, p0 + np.array([-n[1], n[0]]), color="saddlebrown", lw=2, zorder=1,
                      label="ground" if first else None)
        elif isinstance(c, DrumContact) and (moving or not c.body):
            centre = body_positions.get(c.body, c.centre) if c.body else c.centre
            ax.add_patch(Circle(centre, c.radius, fc="0.85", ec="saddlebrown", lw=1.5, zorder=1,
                                label="drum" if first else None))


def draw_loads(ax, result: StaticResult, view: _View, size: float) -> None:
    """Point forces and tensions as arrows ending at their point, distributed loads as a row of small arrows,
    moments as a turning arrow with their value."""
    scene = result.assembly.scene
    length = 0.12 * size
    for load in scene.loads:
        if not np.any(np.asarray(load.value, float)):
            continue  # (a zero load: nothing to draw)
        if load.kind == "force":
            _arrow(ax, view.point(load.member, load.at), np.asarray(load.value, float), length,
                   _vec_text(load.value, "N"))
        elif load.kind == "tension":
            mm = result.assembly.mesh.members[load.member]
            end = mm.node(load.at) == mm.n_nodes - 1
            t = view.tangent(load.member, load.at) * (1 if end else -1)
            p = view.point(load.member, load.at)
            _arrow(ax, p + length * t, t, length, f"{float(load.value):.3g} N")
        elif load.kind == "distributed":
            mm = result.assembly.mesh.members[load.member]
            q = np.asarray(load.value, float)
            for i, s in enumerate(np.linspace(0, mm.length, 7)):
                _arrow(ax, view.point(load.member, float(s)), q, length / 2,
                       _vec_text(q, "N/m") if i == 3 else None)
        elif load.kind == "moment":
            p = view.point(load.member, load.at)
            v = np.atleast_1d(np.asarray(load.value, float))
            sym = ("\u21ba" if v[0] >= 0 else "\u21bb") if len(v) == 1 else "M"
            ax.text(*p, f"{sym} {_vec_text(v, 'N m')}", color=LOAD_COLOR, fontsize=9, ha="left", va="bottom",
                    zorder=6)


def draw_gravity(ax, gravity) -> None:
    """Gravity in the legend: an arrow along it and its magnitude (planar scenes)."""
    if gravity is None or not np.any(gravity):
        return
    from matplotlib.markers import MarkerStyle
    from matplotlib.transforms import Affine2D

    g = np.asarray(gravity, float)[:2]
    angle = math.degrees(math.atan2(g[1], g[0])) + 90  # the arrow glyph points down (-90 deg)
    arrow = MarkerStyle("$\u2193$", transform=Affine2D().rotate_deg(angle))
    ax.plot([], [], ls="none", marker=arrow, ms=12, color="0.3", label=f"gravity {np.linalg.norm(g):.3g} m/s\u00b2")


def plot_shape(result: StaticResult, path: str | Path, per_element: int = 8) -> Path:
    """shape_figure saved as a PNG."""
    return _save(shape_figure(result, per_element), Path(path))


def shape_figure(result: StaticResult, per_element: int = 8) -> Figure:
    """Deformed shape (solid, magnified where small, the factor in the title and legend; never in a scene with
    contacts), the undeformed reference (dashed), supports, joints, contacts and loads of every member."""
    scene, asm = result.assembly.scene, result.assembly
    refs, curs = {}, {}
    for name, mm in asm.mesh.members.items():
        pe = plot_per_element(len(mm.elem_nodes), per_element)
        refs[name] = _decimate(fields.positions(mm, mm.x0, pe))
        curs[name] = _decimate(fields.positions(mm, asm.member_coordinates(result.x, name), pe))
    factor, dmax, size = magnification(list(refs.values()), list(curs.values()))
    if scene.contacts:  # a magnified shape would cross the grounds and drums it touches: drawn as it is
        factor = 1.0
    view = _View(result, factor)
    fig = Figure(figsize=(8, 5), layout="constrained")
    ax = fig.add_subplot(projection="3d" if scene.dim == 3 else None)
    shown = ""
    if factor != 1:
        shown = f" x {factor:g}"
    for k, name in enumerate(scene.members):
        color = f"C{k % 10}"
        ref, cur = refs[name], refs[name] + factor * (curs[name] - refs[name])
        ax.plot(*ref.T, ls="--", lw=1, color=color, alpha=0.5)
        ax.plot(*cur.T, lw=2, color=color, label=f"{name} (deformed{shown})")
        nodes = asm.mesh.members[name].public_nodes
        if len(nodes) <= 60:  # nodes marked where they can be told apart
            n0 = asm.mesh.members[name].x0[nodes, :scene.dim]
            ax.plot(*(n0 + factor * (result.nodes(name) - n0)).T, ls="none", marker="o", ms=3, color=color)
    ax.plot([], [], ls="--", lw=1, color="0.5", label="undeformed")
    draw_supports(ax, result, view)
    draw_loads(ax, result, view, size)
    if scene.dim == 2:
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(True, lw=0.3)
        draw_gravity(ax, scene.gravity)
    else:
        pts = np.vstack([*refs.values(), *(refs[n] + factor * (curs[n] - refs[n]) for n in refs)])
        ax.set_box_aspect(np.maximum(np.ptp(pts, axis=0), 1e-3 * np.ptp(pts, axis=0).max()))
        ax.set_zlabel("z [m]")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    title = f"{scene.name}: {result.status}, max displacement {length_text(dmax)}"
    if factor != 1:
        title += f"\ndisplacements drawn magnified x {factor:g}"
    ax.set_title(title)
    fig.legend(loc="outside right upper", fontsize="small")
    return fig


def plot_fields(result: StaticResult, path: str | Path, per_element: int = 8) -> Path:
    """fields_figure saved as a PNG."""
    return _save(fields_figure(result, per_element), Path(path))


def fields_figure(result: StaticResult, per_element: int = 8) -> Figure:
    """The axial strain each member's energy uses (its measure on the axis or in the legend) [-] and the curvature
    [1/m] against the material coordinate s [m], per member; min/max envelopes where the mesh is finer than the
    screen."""
    scene, asm = result.assembly.scene, result.assembly
    fig = Figure(figsize=(8, 6), layout="constrained")
    ax_e, ax_k = fig.subplots(2, 1, sharex=True)
    measures = {name: fields.axial_measure(m) for name, m in scene.members.items()}
    one = len(set(measures.values())) == 1
    for k, (name, mm) in enumerate(asm.mesh.members.items()):
        # the envelope shows every element's extremes: a few samples per element (ends and middle at least)
        f = fields.sample(mm, asm.member_coordinates(result.x, name), max(2, min(per_element,
                          ENVELOPE_POINTS // len(mm.elem_nodes))))
        ax_e.plot(*envelope(f["s"], f["axial_strain"]), color=f"C{k % 10}",
                  label=name if one else f"{name}: {measures[name]}")
        ax_k.plot(*envelope(f["s"], f["curvature"]), color=f"C{k % 10}", label=name)
    ax_e.set_ylabel("axial strain [-]")
    ax_e.set_title(f"axial strain as the energy measures it: {next(iter(measures.values()))}" if one
                   else "axial strain as each member's energy measures it (legend)", fontsize="medium")
    ax_k.set_ylabel("curvature [1/m]")
    ax_k.set_title("curvature |r_x x r_xx| / |r_x|^3", fontsize="medium")
    ax_k.set_xlabel("material coordinate s [m]")
    for ax in (ax_e, ax_k):
        ax.grid(True, lw=0.3)
        ax.ticklabel_format(axis="y", style="sci", scilimits=(-3, 3))
    fig.legend(*ax_e.get_legend_handles_labels(), loc="outside right upper", fontsize="small")
    fig.suptitle(f"{scene.name}: strain and curvature along the members")
    return fig


def write_plots(result: StaticResult, directory: str | Path, per_element: int = 8) -> list[Path]:
    d = Path(directory)
    return [plot_shape(result, d / "shape.png", per_element), plot_fields(result, d / "fields.png", per_element)]


# -- animations ----------------------------------------------------------------------------------------------------

MAX_FRAMES = 150  # an animation's frames at most (every k-th output time beyond): a GIF of a few MB at most


def oscillation(reference: dict[str, np.ndarray], shape: dict[str, np.ndarray], amplitude: float,
                frames: int = 24) -> list[dict[str, np.ndarray]]:
    """The frames of one period of reference + amplitude sin(phase) shape (member name -> (k, dim) points each):
    a mode shape for animate_shapes."""
    return [{n: reference[n] + amplitude * math.sin(2 * math.pi * i / frames) * shape[n] for n in reference}
            for i in range(frames)]


def animate_shapes(frames: Sequence[dict[str, np.ndarray]], path: str | Path, *,
                   captions: Sequence[str] | None = None, reference: dict[str, np.ndarray] | None = None,
                   title: str = "", fps: float = 20.0,
                   decorate: Callable | None = None, dpi: int = 80) -> Path:
    """A GIF of member shapes: frames[i] maps member name -> (k, dim) centre-line points (planar or spatial);
    captions[i] is shown under the title (e.g. "t = 0.25 s"); reference (dashed) and decorate(ax) (supports,
    contacts) are drawn once. The axes hold every frame's extent (equal scales).

    The still parts are rendered once and each frame draws only the curves and the caption over them (blitting,
    ~3 ms a frame instead of ~90 ms for a full redraw); Pillow (matplotlib's own image dependency, the writer of
    its PillowWriter) writes the GIF with one palette for all frames."""
    from PIL import Image

    names = list(frames[0])
    dim = frames[0][names[0]].shape[1]
    fig = Figure(figsize=(6.4, 4.8), dpi=dpi, layout="constrained")
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_subplot(projection="3d" if dim == 3 else None)
    allpts = np.vstack([np.vstack(list(f.values())) for f in frames]
                       + ([np.vstack(list(reference.values()))] if reference else []))
    lo, hi = allpts.min(axis=0), allpts.max(axis=0)
    pad = 0.05 * max(float((hi - lo).max()), 1e-9)
    if reference:
        for k, n in enumerate(names):
            ax.plot(*reference[n].T, ls="--", lw=1, color=f"C{k % 10}", alpha=0.5)
    if decorate is not None:
        decorate(ax)
    lines = [ax.plot(*frames[0][n].T, lw=2, color=f"C{k % 10}", label=n, animated=True)[0]
             for k, n in enumerate(names)]
    if dim == 2:
        ax.set_xlim(lo[0] - pad, hi[0] + pad)
        ax.set_ylim(lo[1] - pad, hi[1] + pad)
        ax.set_aspect("equal", adjustable="box")
        ax.grid(True, lw=0.3)
    else:
        for setter, a, b in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), lo - pad, hi + pad):
            setter(a, b)
        ax.set_box_aspect(np.maximum(hi - lo, 1e-3 * float((hi - lo).max())))
        ax.set_zlabel("z [m]")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    if len(names) > 1:
        ax.legend(loc="upper right", fontsize="small")
    ax.set_title(f"{title}\n{captions[0]}" if captions is not None else title)
    head = ax.title
    canvas.draw()  # the layout and the still background (animated artists left out)
    fig.set_layout_engine("none")
    head.set_animated(True)
    canvas.draw()
    background = canvas.copy_from_bbox(fig.bbox)
    images = []
    for i, f in enumerate(frames):
        canvas.restore_region(background)
        for line, n in zip(lines, names):
            if dim == 2:
                line.set_data(f[n][:, 0], f[n][:, 1])
            else:
                line.set_data_3d(f[n][:, 0], f[n][:, 1], f[n][:, 2])
            ax.draw_artist(line)
        if captions is not None:
            head.set_text(f"{title}\n{captions[i]}" if title else captions[i])
        ax.draw_artist(head)
        images.append(Image.fromarray(np.asarray(canvas.buffer_rgba())[..., :3].copy()))
    first = images[0].quantize(colors=64)
    rest = [im.quantize(palette=first, dither=Image.Dither.NONE) for im in images[1:]]
    first.save(path, save_all=True, append_images=rest, duration=max(1, round(1000 / fps)), loop=0)
    return Path(path)
