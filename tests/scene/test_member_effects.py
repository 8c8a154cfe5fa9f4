"""A member's options decoded in one place (ancf_sym.scene.member_effects): the table names kernels that exist, the energy
terms a scene builds are exactly the effects the table gives, and the checks built on it refuse bad input when it is
given, naming the field. Also the damping options, checked once by the Python API that the TOML reader calls."""
from __future__ import annotations

import pytest

from ancf_sym import Material, Scene, SceneError, Section
from ancf_sym.scene.member_effects import AXIAL, AXIAL_STRAINS, stiffness_effects
from ancf_sym.model.mesh import build_mesh
from ancf_sym.registry import EFFECTS
from ancf_sym.model.terms import scene_terms

STEEL = Material(E=200e9, density=7800)


def test_every_strain_names_a_generated_kernel():
    for el in ("cable2d", "cable3d"):
        for name, strain in AXIAL_STRAINS.items():
            assert (el, strain.effect) in EFFECTS, (el, name)
            assert strain.rate in ("green", "biot")


CASES = [  # (element, axial, bending, torsion, beam_method)
    *[("cable2d", a, b, False, "continuum") for a in (*AXIAL, None) for b in (True, False) if (a, b) != ("decoupled", False)],
    ("cable3d", "green", True, False, "continuum"),
    ("beam3d", "green", True, True, "continuum"),
    ("beam3d", None, False, False, "elastic_line"),
    ("beam3d", "biot", True, True, "elastic_line"),
]


@pytest.mark.parametrize("element, axial, bending, torsion, method", CASES)
def test_terms_are_the_decoded_effects(element, axial, bending, torsion, method):
    """The scene's energy terms (gravity off) are exactly the (label, effect) pairs stiffness_effects gives."""
    dim = 2 if element == "cable2d" else 3
    s = Scene(dim=dim)
    kw = dict(element=element, beam_method=method, torsion=torsion) if element == "beam3d" else dict(element=element)
    sec = Section.rectangle(0.02, 0.03) if element == "beam3d" else Section.circle(0.01)
    s.member("m", [(0,) * dim, (1,) + (0,) * (dim - 1)], elements=2, material=STEEL, section=sec, axial=axial,
             bending=bending, gravity=False, **kw)
    got = sorted((t.label, t.effect) for t in scene_terms(build_mesh(s)))
    assert got == sorted(stiffness_effects(element, axial, bending, torsion, method))


def test_axial_none_spelled_as_in_toml():
    s = Scene(dim=2)
    m = s.member("c", [(0, 0), (1, 0)], elements=2, material=STEEL, section=Section.circle(0.01), axial="none")
    assert m.axial is None


def test_continuum_gauss_refused_when_given():
    """The continuum beam kernel exists for 5 Gauss points only: refused by Scene.member, naming the field."""
    s = Scene(dim=3)
    with pytest.raises(SceneError, match=r"^members\['b'\]\.gauss: must be one of 5 .*got 3"):
        s.member("b", [(0, 0, 0), (1, 0, 0)], elements=2, material=STEEL, section=Section.rectangle(0.02, 0.03),
                 element="beam3d", gauss=3)
    s.member("b", [(0, 0, 0), (1, 0, 0)], elements=2, material=STEEL, section=Section.rectangle(0.02, 0.03),
             element="beam3d", beam_method="elastic_line", gauss=3)  # the elastic line has every order


def _frame() -> Scene:
    s = Scene(dim=2)
    for name, y in (("a", 0.0), ("b", 1.0)):
        s.member(name, [(0, y), (1, y)], elements=2, material=STEEL, section=Section.circle(0.01))
    return s


@pytest.mark.parametrize("call, field", [
    (lambda s: s.rayleigh(alpha=1.0, members=["a"]), r"rayleigh\.members: alpha .*whole scene"),
    (lambda s: (s.rayleigh(alpha=1.0), s.rayleigh(alpha=2.0)), r"rayleigh\.alpha: the scene has one .*1\.0"),
    (lambda s: s.rayleigh(beta=-1.0), r"rayleigh\.beta: must be >= 0, got -1\.0"),
    (lambda s: s.strain_rate_damping(bending=-1.0), r"strain_rate_damping\.bending: must be >= 0"),
    (lambda s: s.strain_rate_damping(axial=1.0, members=["a", "c"]), r"strain_rate_damping\.members\[1\]: names no"),
])
def test_damping_refused_when_added(call, field):
    with pytest.raises(SceneError, match="^" + field):
        call(_frame())


@pytest.mark.parametrize("table", ["members", "loops"])
def test_repeated_member_name_refused_once(table):
    """Scene.member refuses a repeated name; the TOML reader names the table entry (members[1] / loops[0])."""
    from ancf_sym.io.scene_toml import scene_from_dict

    first = {"name": "c", "points": [[0, 0], [1, 0]], "elements": 2, "material": "steel", "section": "wire"}
    doc = {"scene": {"dim": 2}, "materials": {"steel": {"E": 200e9, "density": 7800}},
           "sections": {"wire": {"shape": "circle", "diameter": 0.01}}, "members": [first]}
    if table == "members":
        doc["members"] = [first, dict(first)]
        where = r"members\[1\]"
    else:
        doc["loops"] = [{"name": "c", "pulleys": [[[0, 0], 0.2], [[1, 0], 0.2]], "elements": 8, "material": "steel",
                         "section": "wire"}]
        where = r"loops\[0\]"
    with pytest.raises(SceneError, match=f"^{where}\\.name: repeats an earlier member's name"):
        scene_from_dict(doc)
    with pytest.raises(SceneError, match=r"^members\['a'\]\.name: repeats"):
        _frame().member("a", [(0, 0), (1, 0)], elements=2, material=STEEL, section=Section.circle(0.01))
