"""The scene fingerprint behind the statics problem cache (scene.fingerprint): equal content, equal digest; any
change of any value, down to one bit of one float, another digest, so a rebuilt scene reuses its problem and a
changed one never does."""
import dataclasses
import threading

import numpy as np
import pytest

from ancf_sym import Material, Scene, Section, solve_static
from ancf_sym.scene import fingerprint
from ancf_sym.statics import problem_for
from ancf_sym.study.statics_studies import zhang_scene


def _scene(E=20e9, gravity=(0.0, -9.81), end=(3.0, 0.0), elements=6, axial="decoupled", tip=None) -> Scene:
    s = Scene(dim=2, gravity=gravity)
    s.member("beam", [(0.0, 0.0), end], elements, Material(E=E, density=7200.0), Section(area=7.854e-5, I=4.909e-10),
             axial=axial)
    s.clamp("beam", "start")
    if tip is not None:
        s.force("beam", "end", tip)
    return s


def test_equal_content_gives_the_same_digest_and_the_same_problem():
    assert fingerprint(_scene()) == fingerprint(_scene())
    assert fingerprint(zhang_scene("green", 18, 5)) == fingerprint(zhang_scene("green", 18, 5))
    assert problem_for(_scene(tip=(0.0, -1.0))) is problem_for(_scene(tip=(0.0, -1.0)))


@pytest.mark.parametrize("change", [
    {"E": np.nextafter(20e9, np.inf)},  # one bit of one float
    {"gravity": (-0.0, -9.81)},  # -0.0 is another float than 0.0
    {"end": (3.0, 1e-300)},
    {"elements": 7},
    {"axial": "green"},
    {"tip": (0.0, -1.0)},
], ids=["E one ulp up", "gravity -0.0", "end point", "elements", "strain", "a load"])
def test_any_changed_value_gives_another_digest(change):
    assert fingerprint(_scene(**change)) != fingerprint(_scene())
    assert problem_for(_scene(**change)) is not problem_for(_scene())


def test_changed_support_or_material_field_gives_another_digest():
    s = _scene()
    s.supports[0] = dataclasses.replace(s.supports[0], at="end")
    assert fingerprint(s) != fingerprint(_scene())
    s = _scene()
    m = s.members["beam"]
    s.members["beam"] = dataclasses.replace(m, material=dataclasses.replace(m.material, poisson=0.3))
    assert fingerprint(s) != fingerprint(_scene())


def test_object_arrays_are_compared_by_their_items():
    """An object array's bytes would be its item pointers: it is serialised item by item instead."""
    a, b = _scene(), _scene()
    a.extra = np.array([1.5, "x"], dtype=object)
    b.extra = np.array([1.5, "x"], dtype=object)
    assert fingerprint(a) == fingerprint(b)
    b.extra = np.array([1.5, "y"], dtype=object)
    assert fingerprint(a) != fingerprint(b)


def test_unserialisable_scene_solves_uncached():
    s = _scene()
    s.lock = threading.Lock()
    assert fingerprint(s) is None
    assert problem_for(s) is not problem_for(s)
    assert solve_static(s).success
