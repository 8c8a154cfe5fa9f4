"""TOML scenes (ancf_sym.io.scene_toml): the bundled scenes give the same equilibrium as the same scene written with
the Python API, and every class of bad input is a SceneError that names the TOML path of the field."""
from __future__ import annotations

import copy
import math
import re
from pathlib import Path

import numpy as np
import pytest
import scipy.optimize

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

from ancf_sym import Material, Scene, SceneError, Section, solve_static
from ancf_sym.io.scene_toml import load_scene, scene_from_dict

ROOT = Path(__file__).resolve().parents[2]
SCENES = ROOT / "examples" / "scenes"


# -- the bundled scenes written with the Python API ---------------------------------------------------------------

def api_cantilever() -> Scene:
    s = Scene(dim=2, gravity=(0, -9.81), name="cantilever")
    s.member("beam", [(0, 0), (3, 0)], elements=18, material=Material(E=20e9, density=7200),
             section=Section(area=7.854e-5, I=4.909e-10), axial="decoupled", bending=True, gravity=True)
    s.clamp("beam", at="start")
    return s


def api_catenary() -> Scene:
    s = Scene(dim=2, gravity=(0, -9.81), name="catenary")
    s.member("rope", [(0, 0), (10, 0)], elements=40, material=Material(E=50e6, density=1100),
             section=Section.circle(0.01), axial="biot", bending=False)
    s.pin("rope", "start")
    s.pin("rope", "end")
    return s


def api_t_frame() -> Scene:
    s = Scene(dim=2, gravity=(0, -9.81), name="t_frame")
    steel, bar = Material(E=200e9, density=7800, poisson=0.3), Section.circle(0.02)
    s.member("post", [(0, 0), (0, 1)], elements=10, material=steel, section=bar, axial="green")
    s.member("crossbar", [(-0.5, 1), (0.5, 1)], elements=10, material=steel, section=bar, axial="green")
    s.clamp("post", "start")
    s.rigid(("post", "end"), ("crossbar", 5))
    s.force("crossbar", "end", (0, -500))
    s.moment("crossbar", "start", 50.0)
    return s


API = {"cantilever": api_cantilever, "catenary": api_catenary, "t_frame": api_t_frame}


@pytest.mark.parametrize("name", sorted(API))
def test_bundled_scene_matches_python_api(name):
    scene, analysis = load_scene(SCENES / f"{name}.toml")
    assert analysis == {"type": "statics"}
    assert scene.name == name
    rt, ra = solve_static(scene), solve_static(API[name]())
    assert rt.success and ra.success, (rt.status, ra.status)
    assert rt.energies.keys() == ra.energies.keys()
    assert rt.potential == pytest.approx(ra.potential, rel=1e-12, abs=1e-12)
    assert list(scene.members) == list(ra.assembly.scene.members)
    for m in scene.members:
        np.testing.assert_allclose(rt.nodes(m), ra.nodes(m), rtol=0, atol=1e-12)
    assert rt.constraint_violation < 1e-9


def test_cantilever_paper000_potential():
    """Paper 000: about -11.47 J for 18 coupled elements; the decoupled strain lands within 0.05 J of it."""
    r = solve_static(load_scene(SCENES / "cantilever.toml")[0])
    assert r.potential == pytest.approx(-11.47, abs=0.05)
    assert r.potential == pytest.approx(-11.493, abs=2e-3)  # this package, 18 decoupled elements (measured)


def test_catenary_matches_elastic_catenary():
    """Irvine's elastic catenary (Hooke on the Biot stretch, exactly the `biot` axial effect): mid-span sag of a
    cable of unstretched length = span, supports level."""
    scene, _ = load_scene(SCENES / "catenary.toml")
    r = solve_static(scene)
    m = scene.members["rope"]
    L0, EA = m.length, m.material.E * m.section.area
    w = m.material.density * m.section.area * 9.81
    W = w * L0
    span = lambda H: H * L0 / EA + 2 * H / w * math.asinh(W / (2 * H)) - L0  # noqa: E731
    H = scipy.optimize.brentq(span, 1e-3 * W, 1e3 * W, xtol=1e-14)
    sag = W * L0 / (8 * EA) + H / w * (math.sqrt(1 + (W / (2 * H)) ** 2) - 1)
    mid = r.nodes("rope")[len(r.nodes("rope")) // 2]
    assert -mid[1] == pytest.approx(sag, rel=1e-4)
    assert "bending" not in r.energies


def test_docs_example_is_the_t_frame():
    """The annotated example of docs/scenes.md parses and is the bundled t_frame."""
    text = (ROOT / "docs" / "scenes.md").read_text()
    block = re.search(r"## Annotated example\s+```toml\n(.*?)```", text, re.S).group(1)
    s_doc, a_doc = scene_from_dict(tomllib.loads(block))
    s_file, a_file = load_scene(SCENES / "t_frame.toml")
    assert a_doc == a_file
    assert list(s_doc.members) == list(s_file.members)
    for name in s_doc.members:
        d, f = s_doc.members[name], s_file.members[name]
        np.testing.assert_array_equal(d.points, f.points)
        assert (d.elements, d.material, d.section, d.axial, d.bending) == (f.elements, f.material, f.section,
                                                                          f.axial, f.bending)
    assert [(l.kind, l.member, l.at) for l in s_doc.loads] == [(l.kind, l.member, l.at) for l in s_file.loads]
    assert len(s_doc.joints) == len(s_file.joints) == 1 and len(s_doc.supports) == len(s_file.supports) == 1


def test_analysis_options_and_dynamics_pass_through():
    doc = tomllib.loads((SCENES / "cantilever.toml").read_text())
    doc["analysis"] = {"type": "statics", "tol": 1e-6, "max_iter": 50, "load_steps": 4, "escape_saddle": False}
    assert scene_from_dict(doc)[1] == doc["analysis"]
    doc["analysis"] = {"type": "dynamics", "dt": 1e-3, "t_end": 2.0, "integrator": "hht", "alpha": -0.1}
    assert scene_from_dict(doc)[1] == doc["analysis"]
    doc["analysis"]["integrator"] = {"name": "hht"}  # dynamics options are checked when the file is read, too
    with pytest.raises(SceneError, match=r"^analysis\.integrator: must be a non-empty string"):
        scene_from_dict(doc)
    doc.pop("analysis")
    assert scene_from_dict(doc)[1] == {"type": "statics"}


# -- bad input: each class names the field ---------------------------------------------------------------------

def _set(path, value):
    """Mutation setting doc[path] (path like "members.1.elements") to value; value None deletes it."""
    keys = [int(k) if k.isdigit() else k for k in path.split(".")]

    def mutate(doc):
        d = doc
        for k in keys[:-1]:
            d = d[k]
        if value is None:
            del d[keys[-1]]
        else:
            d[keys[-1]] = value
    return mutate


BAD = [  # (mutation of t_frame.toml, field path expected at the start of the message, words expected after)
    (_set("members.1.elements", 0), "members[1].elements", "positive integer, got 0"),
    (_set("members.1.elements", 2.5), "members[1].elements", "positive integer, got 2.5"),
    (_set("members.1.elements", True), "members[1].elements", "positive integer"),
    (_set("members.0.elemnts", 3), "members[0].elemnts", "unknown key"),
    (_set("members.0.axial", "hooke"), "members[0].axial", "'hooke'"),
    (_set("members.0.bending", "yes"), "members[0].bending", "true or false"),
    (_set("members.0.points", [[0, 0]]), "members[0].points", ">= 2 points"),
    (_set("members.0.points", [[0, 0], [0, 1, 2]]), "members[0].points[1]", "2 numbers"),
    (_set("members.0.points", [[0, 0], [0, math.nan]]), "members[0].points[1][1]", "finite, got nan"),
    (_set("members.0.material", "wood"), "members[0].material", "names no material"),
    (_set("members.0.section", 3), "members[0].section", "string"),
    (_set("members.0.name", None), "members[0].name", "missing"),
    (_set("members.1.name", "post"), "members[1].name", "repeats"),
    (_set("members.1.element", "cable3d"), "members[1].element", "does not fit a 2D scene, got 'cable3d'"),
    # strings are never numbers, booleans neither: refused in every table (one declared schema)
    (_set("materials.steel.E", "200e9"), "materials.steel.E", "must be a number, got '200e9'"),
    (_set("members.0.prestrain", "0.1"), "members[0].prestrain", "must be a number, got '0.1'"),
    (_set("loads.0.value", ["0", -500.0]), "loads[0].value[0]", "must be a number, got '0'"),
    (_set("analysis.tol", "1e-6"), "analysis.tol", "must be a number, got '1e-6'"),
    (_set("analysis.max_iter", True), "analysis.max_iter", "positive integer, got True"),
    (_set("analysis", {"type": "dynamics", "dt": "1e-3", "t_end": 1.0}), "analysis.dt", "number, got '1e-3'"),
    (_set("analysis", {"type": "dynamics", "dt": 1e-3, "t_end": "1"}), "analysis.t_end", "number, got '1'"),
    (_set("analysis", {"type": "dynamics", "dt": 1e-3, "t_end": 1.0, "rho_inf": "0.5"}), "analysis.rho_inf",
     "number, got '0.5'"),
    (_set("analysis", {"type": "dynamics", "dt": 1e-3, "t_end": 1.0, "adaptive": 1}), "analysis.adaptive",
     "true or false, got 1"),
    (_set("analysis", {"type": "dynamics", "dt": 1e-3, "t_end": 1.0, "output_times": ["0.5"]}),
     "analysis.output_times[0]", "number, got '0.5'"),
    (_set("analysis", {"type": "dynamics", "dt": 1e-3, "t_end": 1.0, "rho_inf": 1.5}), "analysis.rho_inf", "[0, 1]"),
    (_set("analysis", {"type": "dynamics", "dt": 1e-3}), "analysis.t_end", "missing"),
    (_set("analysis", {"type": "dynamics", "dt": 1e-3, "t_end": 1.0, "newton": {"tol": "1e-8"}}),
     "analysis.newton.tol", "got '1e-8'"),
    (_set("analysis", {"type": "dynamics", "dt": 1e-3, "t_end": 1.0, "sensors": [{"kind": "x"}]}),
     "analysis.sensors[0].kind", "got 'x'"),
    (_set("analysis", {"type": "dynamics", "dt": 1e-3, "t_end": 1.0, "dtt": 1}), "analysis.dtt", "unknown key"),
    # a step longer than the whole run is a typo, not a request
    (_set("analysis", {"type": "dynamics", "dt": 0.5, "t_end": 0.1}), "analysis.dt", "must not exceed t_end - t_start"),
    # keys that do not apply to the element are refused, not ignored
    (_set("members.0.y_axis", [0.0, 1.0, 0.0]), "members[0].y_axis", "beam3d members only, not cable2d"),
    (_set("members.0.beam_method", "elastic_line"), "members[0].beam_method", "beam3d members only"),
    # what is wrong with the input, not a consequence of it (overflowing lengths, non-finite coordinates)
    (_set("members.0.points", [[0.0, 0.0], [0.0, 1e300]]), "members[0].points", "within +-1e+12 m"),
    (_set("members.0.points", [[0.0, 0.0], [0.0, 0.0]]), "members[0].points", "distinct"),
    (_set("members.0.bending", "true"), "members[0].bending", "true or false, got 'true'"),
    (_set("loads.1.value", "50"), "loads[1].value", "must be a number, got '50'"),
    (_set("members.0.gauss", 6), "members[0].gauss", "3, 4, 5, 7"),
    (_set("members.0.torsion", True), "members[0].torsion", "beam3d members only, not cable2d"),
    (_set("materials.steel.E", math.inf), "materials.steel.E", "finite, got inf"),
    (_set("materials.steel.E", -1.0), "materials.steel.E", "positive, got -1.0"),
    (_set("materials.steel.density", "heavy"), "materials.steel.density", "number, got 'heavy'"),
    (_set("materials.steel.G", 80e9), "materials.steel", "G or poisson, not both"),
    (_set("materials.steel.poisson", 0.7), "materials.steel.poisson", "(-1, 0.5)"),
    (_set("sections.bar.area", 1.0), "sections.bar.area", "unknown key"),
    (_set("sections.bar.shape", "hexagon"), "sections.bar.shape", "circle | rectangle"),
    (_set("sections.bar.diameter", 0.0), "sections.bar.diameter", "positive"),
    (_set("sections.plain", {"I": 1e-9}), "sections.plain.area", "missing"),
    (_set("supports.0.member", "pots"), "supports[0].member", "names no member"),
    (_set("supports.0.at", 99), "supports[0].at", "nodes 0..10"),
    (_set("supports.0.at", 0.5), "supports[0].at", "node index"),
    (_set("supports.0.type", "weld"), "supports[0].type", "clamp | pin | slope"),
    (_set("supports.0.method", "lagrange"), "supports[0].method", "exact | penalty"),
    (_set("supports.0.penalty", -2.0), "supports[0].penalty", "positive"),
    (_set("supports", None), "supports", "free rigid-body motion"),
    (_set("joints.0.b", ["crossbar", 11]), "joints[0].b", "nodes 0..10, got 11"),
    (_set("joints.0.b", ["crossbar"]), "joints[0].b", "[member, at]"),
    (_set("joints.0.a", ["mast", "end"]), "joints[0].a[0]", "names no member"),
    (_set("joints.0.type", "weld"), "joints[0].type", "hinge | rigid"),
    (_set("loads.0.member", "nope"), "loads[0].member", "names no member"),
    (_set("loads.0.at", 7.5), "loads[0].at", "[0, 1] m, got 7.5"),
    (_set("loads.0.at", -12), "loads[0].at", "nodes 0..10"),
    (_set("loads.0.value", [1, 2, 3]), "loads[0].value", "2 numbers"),
    (_set("loads.0.value", [1, math.inf]), "loads[0].value[1]", "finite"),
    (_set("loads.1.value", [1, 2]), "loads[1].value", "number"),
    (_set("loads.0.type", "distributed"), "loads[0].at", "unknown key"),
    (_set("loads.0.type", None), "loads[0].type", "missing"),
    (_set("loads.0.type", "pressure"), "loads[0].type", "force | distributed | moment | tension"),
    (_set("analysis.max_iter", 0), "analysis.max_iter", "positive integer, got 0"),
    (_set("analysis.tol", -1e-3), "analysis.tol", "(0, 1), got -0.001"),
    (_set("analysis.tolerance", 1e-3), "analysis.tolerance", "unknown key"),
    (_set("analysis.type", "buckling"), "analysis.type", "statics | dynamics | modal"),
    (_set("analysis", {"type": "dynamics", "dt": math.nan}), "analysis.dt", "finite"),
    (_set("scene.dim", 4), "scene.dim", "2 or 3"),
    (_set("scene.dim", None), "scene.dim", "missing"),
    (_set("scene.gravity", [0, 0, -9.81]), "scene.gravity", "2 numbers"),
    (_set("scene.units", "mm"), "scene.units", "unknown key"),
    (_set("extra", 1), "extra", "unknown key"),
    (_set("members", []), "members", "at least one"),
    (_set("members", {"name": "x"}), "members", "array of tables"),
]


@pytest.mark.parametrize("mutate,field,words", BAD, ids=[f"{f}:{w}" for _, f, w in BAD])
def test_bad_input_names_the_field(mutate, field, words):
    doc = tomllib.loads((SCENES / "t_frame.toml").read_text())
    mutate(doc)
    with pytest.raises(SceneError) as exc:
        scene_from_dict(copy.deepcopy(doc))
    msg = str(exc.value)
    assert msg.startswith(f"{field}:"), msg
    assert words in msg, msg


def test_nan_inf_literals_and_bad_files(tmp_path):
    text = (SCENES / "cantilever.toml").read_text()
    for literal in ("nan", "inf", "-inf"):
        p = tmp_path / "nan.toml"
        p.write_text(text.replace("E = 20e9", f"E = {literal}"))
        with pytest.raises(SceneError, match=r"^materials\.paper000\.E: must be finite"):
            load_scene(p)
    p = tmp_path / "syntax.toml"
    p.write_text(text.replace("elements = 18", "elements = "))
    with pytest.raises(SceneError, match="not valid TOML"):
        load_scene(p)
    with pytest.raises(SceneError, match="not found"):
        load_scene(tmp_path / "missing.toml")


# -- dampings (dynamics) -----------------------------------------------------------------------------------------

def test_dampings_match_python_api():
    doc = tomllib.loads((SCENES / "t_frame.toml").read_text())
    doc["dampings"] = [{"type": "rayleigh", "alpha": 0.5}, {"type": "rayleigh", "beta": 1e-3, "members": ["post"]},
                       {"type": "strain_rate", "axial": 100.0, "bending": 0.5, "members": ["crossbar"]},
                       {"type": "strain_rate", "bending": 2}]
    scene, _ = scene_from_dict(doc)
    api = api_t_frame()
    api.rayleigh(alpha=0.5)
    api.rayleigh(beta=1e-3, members=["post"])
    api.strain_rate_damping(axial=100.0, bending=0.5, members=["crossbar"])
    api.strain_rate_damping(bending=2.0)
    assert scene.dampings == api.dampings


def test_dampings_run_in_dynamics():
    """A TOML Rayleigh damping reaches the dynamics: the released cantilever books damping work."""
    from ancf_sym.dynamics import run_dynamics
    doc = tomllib.loads((SCENES / "cantilever.toml").read_text())
    doc["dampings"] = [{"type": "rayleigh", "alpha": 2.0}, {"type": "strain_rate", "axial": 50.0}]
    doc["analysis"] = {"type": "dynamics", "dt": 1e-3, "t_end": 0.05, "output_every": 10}
    scene, analysis = scene_from_dict(doc)
    r = run_dynamics(scene, analysis)
    assert r.status == "completed" and r.energies["damping_work"][-1] > 0


DAMPING_BAD = [  # (dampings array, field path expected at the start of the message, words expected after)
    ([{"type": "viscous", "alpha": 1.0}], "dampings[0].type", "rayleigh | strain_rate"),
    ([{"alpha": 1.0}], "dampings[0].type", "missing"),
    ([{"type": "rayleigh", "axial": 1.0}], "dampings[0].axial", "unknown key"),
    ([{"type": "rayleigh"}], "dampings[0]", "alpha and/or beta"),
    ([{"type": "strain_rate", "members": ["post"]}], "dampings[0]", "axial and/or bending"),
    ([{"type": "rayleigh", "beta": -1e-3}], "dampings[0].beta", ">= 0, got -0.001"),
    ([{"type": "rayleigh", "alpha": math.inf}], "dampings[0].alpha", "finite"),
    ([{"type": "strain_rate", "axial": "much"}], "dampings[0].axial", "number, got 'much'"),
    ([{"type": "strain_rate", "axial": True}], "dampings[0].axial", "number, got True"),
    ([{"type": "strain_rate", "axial": 1.0, "members": ["mast"]}], "dampings[0].members[0]", "names no member"),
    ([{"type": "strain_rate", "axial": 1.0, "members": "post"}], "dampings[0].members", "array of member names"),
    ([{"type": "strain_rate", "axial": 1.0, "members": []}], "dampings[0].members", "non-empty"),
    ([{"type": "rayleigh", "alpha": 1.0, "members": ["post"]}], "dampings[0].members", "whole scene"),
    ([{"type": "rayleigh", "alpha": 1.0}, {"type": "rayleigh", "alpha": 2.0}], "dampings[1].alpha", "1.0"),
    ({"type": "rayleigh", "alpha": 1.0}, "dampings", "array of tables"),
]


@pytest.mark.parametrize("dampings,field,words", DAMPING_BAD, ids=[f"{f}:{w}" for _, f, w in DAMPING_BAD])
def test_bad_dampings_name_the_field(dampings, field, words):
    doc = tomllib.loads((SCENES / "t_frame.toml").read_text())
    doc["dampings"] = dampings
    with pytest.raises(SceneError) as exc:
        scene_from_dict(doc)
    msg = str(exc.value)
    assert msg.startswith(f"{field}:"), msg
    assert words in msg, msg


def test_strain_rate_damping_of_a_beam3d_is_refused():
    doc = {"scene": {"dim": 3}, "materials": {"steel": {"E": 200e9, "density": 7800}},
           "sections": {"bar": {"shape": "rectangle", "b": 0.02, "h": 0.03}},
           "members": [{"name": "beam", "points": [[0, 0, 0], [1, 0, 0]], "elements": 2, "material": "steel",
                        "section": "bar", "element": "beam3d"}],
           "supports": [{"type": "clamp", "member": "beam"}],
           "dampings": [{"type": "strain_rate", "axial": 1.0}]}
    with pytest.raises(SceneError, match=r"^dampings\[0\]: .*beam3d"):
        scene_from_dict(doc)
