"""A scene pays only for the effects it names (docs/performance.md): no bending kernel for a cable without bending, no term
for a zero-stiffness effect, the planar element (8 DOF) for a planar scene. The cost of each effect is measured by
bench/effects.py."""
from __future__ import annotations

import pytest

from ancf_sym import Material, Scene, Section, kernels, solve_static
from ancf_sym.model.assembly import Assembly

STEEL = Material(E=200e9, density=7800)


def cable_scene(dim=2, bending=False, axial="biot", gravity=(0, -9.81), elements=10) -> Scene:
    g = tuple(gravity) if dim == 2 else (0, 0, -9.81) if any(gravity) else (0, 0, 0)
    s = Scene(dim=dim, gravity=g)
    end = (4, 0) if dim == 2 else (4, 0, 0)
    s.member("cable", [(0,) * dim, end], elements=elements, material=STEEL, section=Section.circle(0.005),
             axial=axial, bending=bending)
    s.pin("cable", "start")
    s.pin("cable", "end")
    return s


@pytest.fixture
def loaded(monkeypatch):
    """Every (element, effect) the run-time path asks the kernel loader for."""
    seen = []
    load, load_energy = kernels.load, kernels.load_energy

    def rec_load(element, effect, gauss=None):
        seen.append((element, effect))
        return load(element, effect, gauss)

    def rec_energy(element, effect, gauss=None):
        seen.append((element, effect))
        return load_energy(element, effect, gauss)

    monkeypatch.setattr(kernels, "load", rec_load)
    monkeypatch.setattr(kernels, "load_energy", rec_energy)
    return seen


def test_cable_without_bending_never_loads_or_calls_bending(loaded):
    s = cable_scene(bending=False)
    asm = Assembly(s)
    assert {t.effect for t in asm.terms} == {"axial_biot", "gravity"}
    assert all(mk.kernel.effect != "bending" for mk in asm.mapped)
    r = solve_static(asm)  # the IPOPT graph (energy functions and their companions) goes through the loader too
    assert r.success
    assert "bending" not in r.energies
    assert loaded and all(effect != "bending" for _, effect in loaded), loaded
    assert {effect for _, effect in loaded} == {"axial_biot", "gravity"}


def test_bending_is_loaded_when_asked(loaded):
    asm = Assembly(cable_scene(bending=True))
    assert ("cable2d", "bending") in loaded
    assert {t.label for t in asm.terms} == {"axial", "bending", "gravity"}


def test_zero_stiffness_effects_are_absent():
    no_gravity = Assembly(cable_scene(gravity=(0, 0)))
    assert "gravity" not in {t.effect for t in no_gravity.terms}
    no_axial = Assembly(cable_scene(axial=None, bending=True))
    assert {t.label for t in no_axial.terms} == {"bending", "gravity"}
    s = cable_scene()
    s.members["cable"].gravity = False  # member opts out of a non-zero scene gravity
    assert {t.effect for t in Assembly(s).terms} == {"axial_biot"}
    assert "gravity" not in Assembly(s).evaluate(Assembly(s).x0).energies


def test_planar_scene_uses_the_planar_element():
    planar, spatial = Assembly(cable_scene(dim=2, bending=True)), Assembly(cable_scene(dim=3, bending=True))
    assert {t.element for t in planar.terms} == {"cable2d"}
    assert all(t.idx.shape == (10, 8) for t in planar.terms)
    assert planar.n == 11 * 4
    assert {t.element for t in spatial.terms} == {"cable3d"}
    assert all(t.idx.shape == (10, 12) for t in spatial.terms)
    assert spatial.n == 11 * 6
