"""Plots a user reads at a glance (shape.png, fields.png, history.png, motion.gif) and outputs that stay proportional
to the model: units and component names on the axes, only the energy terms that are not zero, a stated
magnification of small deflections, the strain the model's energy uses, an animation of dynamics runs (and a flag to
skip it), and the outputs of a 20 000-element run (their cost against the solve: bench/output_cost.py)."""
from __future__ import annotations

import json
from pathlib import Path

import meshio
import numpy as np
import pytest
from PIL import Image

from helpers import cli

from ancf_sym.model import fields
from ancf_sym.dynamics import DynamicOptions, simulate
from ancf_sym.io.dynamics_output import energy_terms, history_figure
from ancf_sym.elements.quadrature import gauss01
from ancf_sym.io.plots import MAX_POINTS, SHOWN_DEFLECTION, SMALL_DEFLECTION, animate_shapes, envelope, fields_figure, member_shapes, oscillation, shape_figure
from ancf_sym.registry import EFFECTS
from ancf_sym.scene import Material, Scene, Section
from ancf_sym.statics import solve_static

ROOT = Path(__file__).resolve().parents[2]
STEEL = dict(material=Material(E=210e9, density=7850.0), section=Section(area=np.pi * 1e-4, I=np.pi / 4 * 1e-8))


def cantilever(force: float, elements: int = 10, axial: str = "decoupled") -> Scene:
    """A 2 m steel rod (20 mm diameter) clamped at x = 0, a downward tip force, no gravity."""
    s = Scene(dim=2, name="rod")
    s.member("arm", points=[(0, 0), (2, 0)], elements=elements, axial=axial, gravity=False, **STEEL)
    s.clamp("arm", at="start")
    s.force("arm", at="end", force=(0.0, -force))
    return s


def pendulum(t_end: float = 0.1) -> tuple[Scene, DynamicOptions]:
    s = Scene(dim=2, gravity=(0.0, -9.81), name="pendulum")
    s.member("beam", points=[(0, 0), (1, 0)], elements=3, axial="decoupled", **STEEL)
    s.pin("beam", at="start")
    return s, DynamicOptions(dt=1e-3, t_end=t_end, output_dt=0.01,
                             sensors=[{"name": "tip", "kind": "position", "member": "beam", "at": "end"},
                                      {"name": "bend", "kind": "curvature", "member": "beam", "at": 0.5}])


def test_history_axes_carry_units_and_component_names():
    s, opts = pendulum()
    r = simulate(s, opts)
    assert r.success
    fig = history_figure(r)
    axes = fig.axes
    labels = [ax.get_ylabel() for ax in axes]
    # every panel names its unit in brackets; the position panel has one curve per component, named x and y
    assert all("[" in lab and lab.endswith("]") for lab in labels), labels
    pos = next(ax for ax in axes if ax.get_ylabel() == "tip: position [m]")
    assert [ln.get_label() for ln in pos.get_lines()] == ["x", "y"]
    assert any(lab == "bend: curvature [1/m]" for lab in labels)
    assert axes[-1].get_xlabel() == "time t [s]"
    assert not any("[0]" in ln.get_label() for ax in axes for ln in ax.get_lines())


def test_zero_energy_terms_are_not_drawn():
    """A pendulum without damping or time loads: damping_work and external_work are zero at every output time and
    are left out (named in the legend's title); every energy curve drawn is not zero."""
    s, opts = pendulum()
    r = simulate(s, opts)
    assert not np.any(r.energies["damping_work"]) and not np.any(r.energies["external_work"])
    terms, zero = energy_terms(r.energies)
    assert {"damping_work", "external_work"} <= set(zero)
    energy_ax = next(ax for ax in history_figure(r).axes if ax.get_ylabel() == "energy [J]")
    drawn = {ln.get_label(): np.asarray(ln.get_ydata()) for ln in energy_ax.get_lines()}
    assert set(drawn) == set(terms) and "kinetic" in drawn
    assert not any("damping" in k or "time loads" in k for k in drawn)
    assert all(np.max(np.abs(v)) > 0 for v in drawn.values())


def test_small_deflection_is_magnified_and_stated():
    """EI = 210e9 * 7.85e-9 = 1650 N m^2, P = 5 N at L = 2 m: tip deflection P L^3 / (3 EI) = 8.1 mm, 0.4% of the
    length: drawn magnified by a 1-2-5 factor so that it shows as 5-15% of the length (SHOWN_DEFLECTION with the
    1-2-5 rounding down to at most 1/2.5 of it), the factor in the title and the legend; the drawn tip is the
    reference tip + factor x the computed displacement."""
    r = solve_static(cantilever(5.0))
    assert r.success
    tip = r.tip("arm")
    assert 7e-3 < -tip[1] < 9e-3
    fig = shape_figure(r)
    ax = fig.axes[0]
    title = ax.get_title()
    assert "magnified x" in title
    factor = float(title.rsplit("magnified x", 1)[1])
    assert SHOWN_DEFLECTION / 2.5 <= factor * (-tip[1]) / 2.0 <= SHOWN_DEFLECTION
    deformed = next(ln for ln in ax.get_lines() if ln.get_label().startswith("arm (deformed x"))
    y_tip = np.asarray(deformed.get_ydata())[-1]
    assert abs(y_tip - factor * tip[1]) < 1e-9
    shown = title.split("max displacement ", 1)[1].split("\n")[0]  # the true size, in a readable unit
    assert shown.endswith(" mm") and abs(float(shown[:-3]) * 1e-3 - np.linalg.norm(tip - (2.0, 0.0))) < 1e-5


def test_large_deflection_is_drawn_as_is():
    """P = 2 kN: tip deflection ~ 3 m (nonlinear), far above SMALL_DEFLECTION of the length: factor 1, no claim."""
    r = solve_static(cantilever(2000.0))
    assert r.success and -r.tip("arm")[1] > SMALL_DEFLECTION * 2.0
    ax = shape_figure(r).axes[0]
    assert "magnified" not in ax.get_title()
    deformed = next(ln for ln in ax.get_lines() if ln.get_label() == "arm (deformed)")
    assert abs(np.asarray(deformed.get_ydata())[-1] - r.tip("arm")[1]) < 1e-9


def test_supports_and_loads_are_drawn():
    r = solve_static(cantilever(5.0))
    fig = shape_figure(r)
    labels = [h.get_label() for h in fig.legends[0].legend_handles]
    assert "clamp support" in labels
    ax = fig.axes[0]
    assert any(t.get_text() == "5 N" for t in ax.texts)  # the tip force's arrow and value


@pytest.mark.parametrize("axial", ["green", "biot", "decoupled"])
def test_plotted_strain_is_the_models_measure(axial):
    """The axial energy is 1/2 int EA eps^2 dx with the member's measure eps at its Gauss points: integrating the
    plotted strain (fields.axial_strain) by the same rule reproduces the kernel's energy (same quadrature, same
    formula: agreement to summation round-off, 1e-9 relative is far above it and far below any other measure's
    difference). A tip moment bends the rod to about a quarter circle and a tip force stretches it, so the measures
    differ; fields.png draws that strain and names the measure in its title."""
    s = Scene(dim=2, name="rod")
    s.member("arm", points=[(0, 0), (2, 0)], elements=6, axial=axial, gravity=False,
             material=Material(E=1e7, density=1000.0), section=Section(area=1e-4, I=1e-9))
    s.clamp("arm", at="start")
    s.moment("arm", at="end", moment=0.01 * np.pi / 4)  # EI pi / (2 L): about a quarter circle
    s.force("arm", at="end", force=(0.0, 0.5))
    r = solve_static(s)
    assert r.success
    mm = r.assembly.mesh.members["arm"]
    xn = r.assembly.member_coordinates(r.x, "arm")
    gauss = EFFECTS[("cable2d", f"axial_{axial}")].default_gauss
    xg, wg = gauss01(gauss)
    EA = 1e7 * 1e-4

    def energy(eps):
        return float(np.sum(EA / 2 * eps**2 @ wg * mm.elem_length))

    U = r.energies["axial"]
    assert abs(energy(fields.axial_strain(mm, xn, xg)) - U) <= 1e-9 * U
    g = np.einsum("ekd,ekd->ek", *[fields.element_fields(mm, xn, xg)[1]] * 2)
    others = {"green": (g - 1) / 2, "biot": np.sqrt(g) - 1}
    # the test tells the measures apart: Green - Biot = eps^2 / 2 at each point, a relative energy difference of
    # about the strain (~1e-5 here); the coupled measures of a bent decoupled element differ by their spurious
    # bending strain (far more); both far above the 1e-9 of the equality
    for name, eps in others.items():
        if name != axial:
            assert abs(energy(eps) - U) > 1e-6 * U, name
    ax = fields_figure(r).axes[0]
    assert fields.MEASURES[axial] in ax.get_title() and ax.get_ylabel() == "axial strain [-]"
    along = r.along("arm", per_element=8)
    np.testing.assert_array_equal(ax.get_lines()[0].get_ydata(), along["axial_strain"])


def test_decoupled_strain_is_smooth_where_the_stretch_oscillates():
    """The bundled cantilever (decoupled strain, 18 elements, large deflection): |r_x| - 1 jumps from element to
    element (the element folds freely in the decoupled energy), the equivalent rod's strain does not: its largest
    jump between neighbouring samples is a small part of its range, the stretch's is larger than its own mean."""
    from ancf_sym.io.scene_toml import load_scene
    scene, _ = load_scene(ROOT / "examples" / "scenes" / "cantilever.toml")
    r = solve_static(scene)
    f = r.along("beam", per_element=8)
    rod, stretch = f["axial_strain"], f["strain"]
    assert np.max(np.abs(np.diff(rod))) < 0.1 * np.ptp(rod)
    assert np.max(np.abs(np.diff(stretch))) > np.mean(np.abs(stretch))


def test_envelope_keeps_every_extreme():
    s = np.linspace(0, 1, 200_001)
    v = np.sin(40 * s) + 1e-3 * (-1.0) ** np.arange(len(s))  # a fast oscillation on a slow wave
    se, ve = envelope(s, v, bins=500)
    assert len(se) == 1000 and ve.max() == v.max() and ve.min() == v.min()
    # each bin's band holds the samples of that bin
    edges = np.linspace(0, 1, 501)
    k = 123
    inside = v[(s >= edges[k]) & (s < edges[k + 1])]
    assert ve[2 * k] == inside.min() and ve[2 * k + 1] == inside.max()


def test_gif_for_a_dynamics_run_and_the_flag_that_skips_it(tmp_path):
    scene = (ROOT / "examples" / "scenes" / "pendulum.toml").read_text().replace("t_end = 1.0", "t_end = 0.1")
    path = tmp_path / "pendulum.toml"
    path.write_text(scene)
    r = cli("run", path, "--out", tmp_path / "a", "--quiet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    gif = tmp_path / "a" / "motion.gif"
    n_out = len(json.loads((tmp_path / "a" / "result.json").read_text())["t"])
    with Image.open(gif) as im:
        assert im.format == "GIF" and im.n_frames == n_out == 6  # every output time (0, 0.02, ..., 0.1)
    r = cli("run", path, "--out", tmp_path / "b", "--quiet", "--no-animation", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "b" / "history.png").is_file() and not (tmp_path / "b" / "motion.gif").exists()


def test_animate_a_mode_shape(tmp_path):
    """The reusable animation of member shapes, as a mode would use it: one period of reference + a sin(phase)
    shape; frames drawn in order (the first and a quarter period differ, the first and the last are close)."""
    r = solve_static(cantilever(5.0))
    ref = member_shapes(r.assembly, r.assembly.x0)
    shape = {n: member_shapes(r.assembly, r.x)[n] - ref[n] for n in ref}
    frames = oscillation(ref, shape, amplitude=20.0, frames=12)
    assert len(frames) == 12
    np.testing.assert_allclose(frames[3]["arm"], ref["arm"] + 20.0 * shape["arm"])
    path = animate_shapes(frames, tmp_path / "mode.gif", captions=[f"phase {i}/12" for i in range(12)],
                          reference=ref, title="mode 1")
    with Image.open(path) as im:
        assert im.n_frames == 12
        im.seek(0)
        a = np.asarray(im.convert("L"), float)
        im.seek(3)
        b = np.asarray(im.convert("L"), float)
    assert np.abs(a - b).mean() > 0.5  # the shape moved between the frames


def test_outputs_of_a_20000_element_run_complete_and_stay_at_screen_resolution(tmp_path):
    """The bundled cantilever at 20 000 elements through the CLI: every output is written; the VTK holds the samples
    samples_per_element allows (8 per element up to 200 000 points), result.json every node; the plots' curves are
    decimated to about MAX_POINTS points (what a screen shows), not 160 000."""
    text = (ROOT / "examples" / "scenes" / "cantilever.toml").read_text().replace("elements = 18", "elements = 20000")
    path = tmp_path / "big.toml"
    path.write_text(text)
    out = tmp_path / "out"
    r = cli("run", path, "--out", out, "--quiet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    doc = json.loads((out / "result.json").read_text())
    assert doc["success"] and len(doc["members"]["beam"]["nodes"]) == 20_001
    mesh = meshio.read(out / "result.vtu")
    assert len(mesh.points) == 20_000 * 8 + 1 and "axial_strain" in mesh.point_data
    for png in ("shape.png", "fields.png"):
        assert (out / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"

    from ancf_sym.io.scene_toml import load_scene
    scene, _ = load_scene(path)
    res = solve_static(scene)
    for fig in (shape_figure(res), fields_figure(res)):
        assert max(len(ln.get_xdata()) for ax in fig.axes for ln in ax.get_lines()) <= 2 * MAX_POINTS + 2
