"""The Python front door refuses what the TOML reader refuses, with the same field paths: the user-facing fields are
declared once (ancf_sym.scene.schema) and checked by the classes themselves. Strings are never numbers, booleans neither;
values are printed as written (no numpy reprs); keys that do not apply to the element are refused."""
from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

from ancf_sym import Material, Scene, SceneError, Section
from ancf_sym.dynamics import DynamicOptions
from ancf_sym.scene.schema import DYNAMIC_OPTIONS, MATERIAL, SECTION, STATIC_OPTIONS
from ancf_sym.statics import StaticOptions

STEEL = dict(material=Material(E=200e9, density=7800.0), section=Section(area=1e-4, I=1e-9))


@pytest.mark.parametrize("cls, table", [(Material, MATERIAL), (Section, SECTION), (StaticOptions, STATIC_OPTIONS),
                                        (DynamicOptions, DYNAMIC_OPTIONS)])
def test_each_table_declares_exactly_its_class_fields(cls, table):
    """One declaration per field: a field added to a class without its declaration (or the reverse) fails here."""
    assert set(table) == {f.name for f in dataclasses.fields(cls)}


@pytest.mark.parametrize("call, path, words", [
    (lambda: Section(area="1e-4"), "section.area", "must be a number, got '1e-4'"),
    (lambda: Section(area=1e-4, I=True), "section.I", "must be a number, got True"),
    (lambda: Material(E="200e9", density=7800.0), "material.E", "must be a number, got '200e9'"),
    (lambda: Material(E=np.float64(-1.0), density=7800.0), "material.E", "must be positive, got -1.0"),
    (lambda: Material(E=1e9, density=1e3, poisson=np.float32(0.5)), "material.poisson", "(-1, 0.5), got 0.5"),
    (lambda: Material(E=1e9, density=1e3, G=1e8, poisson=0.3), "material", "G or poisson, not both"),
    (lambda: StaticOptions(max_iter="50"), "analysis.max_iter", "positive integer, got '50'"),
    (lambda: StaticOptions(tol=np.float64(1.0)), "analysis.tol", "must lie in (0, 1), got 1.0"),
    (lambda: StaticOptions(escape_saddle=1), "analysis.escape_saddle", "true or false, got 1"),
    (lambda: DynamicOptions(dt="1e-3", t_end=1.0), "analysis.dt", "must be a number, got '1e-3'"),
    (lambda: DynamicOptions(dt=1e-3, t_end="1"), "analysis.t_end", "must be a number, got '1'"),
    (lambda: DynamicOptions(dt=1e-3, t_end=1.0, rho_inf="0.9"), "analysis.rho_inf", "number, got '0.9'"),
    (lambda: DynamicOptions(dt=1e-3, t_end=1.0, stages=np.int64(9)), "analysis.stages", "1..4, got 9"),
    (lambda: DynamicOptions(dt=0.5, t_end=0.1), "analysis.dt", "must not exceed t_end - t_start = 0.1 s, got 0.5"),
    (lambda: DynamicOptions(dt=1e-3, t_end=np.float64(0.0)), "analysis.t_end", "greater than t_start = 0, got 0.0"),
])
def test_python_api_names_the_field_and_prints_the_value_plainly(call, path, words):
    with pytest.raises(SceneError) as exc:
        call()
    msg = str(exc.value)
    assert msg.startswith(f"{path}: ") and words in msg, msg
    assert "np." not in msg and "float64" not in msg, msg


@pytest.mark.parametrize("kw, path, words", [
    ({"y_axis": (0.0, 1.0, 0.0)}, "members['rope'].y_axis", "beam3d members only, not cable3d"),
    ({"beam_method": "elastic_line"}, "members['rope'].beam_method", "beam3d members only"),
    ({"elements": 2.0}, "members['rope'].elements", "positive integer, got 2.0"),
    ({"bending": "no"}, "members['rope'].bending", "true or false, got 'no'"),
    ({"prestrain": "0"}, "members['rope'].prestrain", "must be a number, got '0'"),
    ({"points": [(0, 0, 0), ("1", 0, 0)]}, "members['rope'].points[1][0]", "must be a number, got '1'"),
])
def test_member_keys_are_checked_against_the_element(kw, path, words):
    s = Scene(dim=3)
    args = {"points": [(0, 0, 0), (1, 0, 0)], "elements": 2, **STEEL, **kw}
    with pytest.raises(SceneError) as exc:
        s.member("rope", **args)
    assert str(exc.value).startswith(f"{path}: ") and words in str(exc.value), str(exc.value)
    beam = s.member("beam", points=[(0, 0, 0), (1, 0, 0)], elements=2, element="beam3d", beam_method="elastic_line",
                    material=STEEL["material"], section=Section.rectangle(0.02, 0.02), y_axis=(0, 1, 0), torsion=True)
    assert beam.beam_method == "elastic_line" and np.allclose(beam.y_axis, (0, 1, 0))


def test_huge_coordinates_are_refused_as_such_without_numpy_warnings():
    """1e300 m is finite but its square overflows: the user hears about the coordinate, not about a warm start or
    an overflow deep inside the assembly."""
    s = Scene(dim=2)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a RuntimeWarning would fail here
        with pytest.raises(SceneError, match=r"^members\['c'\]\.points: coordinates must lie within \+-1e\+12 m .*"
                                             r"got 1e\+300"):
            s.member("c", points=[(0, 0), (1e300, 0)], elements=2, **STEEL)


@pytest.mark.parametrize("method", ["exact", "penalty"])
def test_support_forces_are_the_forces_on_the_supports(method):
    """Documented sign (docs/scenes.md, result.json's constraint_forces_sign): position rows are the force the
    structure exerts ON the support. A weightless cantilever with a downward tip load F: static balance of the beam
    makes the clamp's force on the beam +F (up), so the value is -F in y and 0 in x; the penalty method's spring
    forces carry the same sign (tolerance: the penalty's compliance and IPOPT's tolerance, far below 1e-6 F)."""
    from ancf_sym import solve_static
    F = 10.0
    s = Scene(dim=2)
    s.member("beam", points=[(0, 0), (1, 0)], elements=4, gravity=False, **STEEL)
    s.clamp("beam", at="start", method=method)
    s.force("beam", at="end", force=(0.0, -F))
    r = solve_static(s)
    assert r.success
    fx, fy = r.constraint_forces["clamp beam@start"][:2]
    assert abs(fy + F) < 1e-6 * F and abs(fx) < 1e-6 * F, (fx, fy)
    from ancf_sym.io.json_out import static_result_dict
    doc = static_result_dict(r)
    assert doc["constraint_forces"]["clamp beam@start"][:2] == [fx, fy]
    assert "ON the support" in doc["constraint_forces_sign"]


def test_docs_list_the_declared_analysis_options():
    """docs/scenes.md shows the options table generated from the declaration: a field added, renamed or re-typed
    without the page following fails here."""
    from pathlib import Path
    from ancf_sym.scene.schema import analysis_table
    page = (Path(__file__).resolve().parents[2] / "docs" / "scenes.md").read_text()
    assert analysis_table() in page
