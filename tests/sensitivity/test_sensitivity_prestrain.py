"""A member's prestrain as a parameter: the length identity of every cable kernel, and static, modal and mode-shape
sensitivities against central differences of re-solved scenes.

References are Richardson-extrapolated central differences (truncation O(h^4): ~1e-8 relative at h = 1e-2 |p| for
responses smooth on the scale of p; Newton converges to round-off, so round-off / h ~ 1e-11): far below the 1e-6 the
derivatives must meet, while a missing term of the identity (a coefficient's weight, the positions' part, the third
derivatives, the mass's L^3 slope terms) errs by O(1)."""
from __future__ import annotations

import copy

import numpy as np
import pytest

from ancf_sym import kernels, registry
from ancf_sym.io.scene_toml import scene_from_dict
from ancf_sym.modal import modal_analysis
from ancf_sym.sensitivity import get_parameter, with_parameter
from ancf_sym.sensitivity.api import sensitivities
from ancf_sym.sensitivity.length_derivative import WEIGHTS, LengthPiece
from ancf_sym.sensitivity.modal import ModalSensitivity
from ancf_sym.sensitivity.model_derivative import ParameterError
from ancf_sym.sensitivity.static import StaticSensitivity
from ancf_sym.statics import solve_static

# an inclined, sagging stay cable with a little bending stiffness, pinned at both ends, drawn with 0.2 % prestrain
DOC = {
    "scene": {"name": "stay", "dim": 2, "gravity": [0.0, -9.81]},
    "materials": {"steel": {"E": 2e10, "density": 7850.0}},
    "sections": {"strand": {"area": 1e-4, "I": 2e-9}},
    "members": [{"name": "c", "points": [[0, 0], [8.0, 4.0]], "elements": 10, "material": "steel",
                 "section": "strand", "axial": "biot", "bending": True, "prestrain": 2e-3}],
    "supports": [{"type": "pin", "member": "c", "at": "start"}, {"type": "pin", "member": "c", "at": "end"}],
    "loads": [{"type": "force", "member": "c", "at": 5, "value": [0.0, -40.0]},
              {"type": "distributed", "member": "c", "value": [3.0, 0.0]}],
    "masses": [{"member": "c", "at": 3, "mass": 2.0}],
}
PATH = "members[0].prestrain"


def richardson(f, doc, path, h=None):
    v = get_parameter(doc, path)
    h = h if h is not None else 1e-2 * abs(v)

    def D(s):
        return (f(with_parameter(doc, path, v + s)) - f(with_parameter(doc, path, v - s))) / (2 * s)
    return (4 * D(h / 2) - D(h)) / 3


def _kernel_cases():
    for element in ("cable2d", "cable3d"):
        for effect in WEIGHTS:
            if (element, effect) in registry.EFFECTS:
                yield element, effect


@pytest.mark.parametrize("element, effect", list(_kernel_cases()))
def test_length_identity_matches_differences_in_L(element, effect):
    """L d(e, g, H)/dL of the compiled kernel from the identity of a unit change, against differences of the kernel
    in its input L (a general state: stretched, bent, off the axes)."""
    rng = np.random.default_rng(7)
    dim = registry.ELEMENTS[element].dim
    L = 0.7
    ex = np.eye(dim)[0]
    q = np.r_[rng.normal(size=dim), 1.1 * ex + 0.1 * rng.normal(size=dim), L * ex + 0.1 * rng.normal(size=dim),
              1.05 * ex + 0.1 * rng.normal(size=dim)]
    values = {"L": L, "EA": 3.0, "EI": 0.2, "rhoA": 2.0, "xi": 0.3, "M": 1.5}
    p = np.array([values.get(n, 0.5 + rng.random()) for n in kernels.parameters(element, effect)])
    k = kernels.load(element, effect, None)

    def f(Lv):
        pp = p.copy()
        pp[0] = Lv
        e, g, H = k(q, pp)
        return np.r_[e, g.ravel(), H.ravel()]
    h = 1e-3 * L
    D = lambda s: (f(L + s) - f(L - s)) / (2 * s)
    fd = (4 * D(h / 2) - D(h)) / 3 * L
    pc = LengthPiece(element, effect, None, np.arange(len(q))[None, :], p[None, :], "x", 1.0)
    e, g = pc.grad(q)
    nd = len(q)
    got = np.r_[e, g.ravel()]
    # (truncation (h/L)^4 ~ 1e-12, round-off ~1e-13 / 1e-3: 1e-8 leaves a margin and catches any missing term)
    assert np.abs(got - fd[:1 + nd]).max() <= 1e-8 * np.abs(fd[:1 + nd]).max()
    if registry.has_third_derivatives(element, effect, None):
        H = pc.hessian(q)[0].ravel()
        assert np.abs(H - fd[1 + nd:]).max() <= 1e-8 * np.abs(fd[1 + nd:]).max()


def static_outputs(doc) -> np.ndarray:
    scene, _ = scene_from_dict(doc)
    r = solve_static(scene)
    assert r.success
    cf = r.constraint_forces
    return np.r_[r.x, r.potential, np.concatenate([np.asarray(cf[k]) for k in sorted(cf)]),
                 [r.energies[k] for k in sorted(r.energies)]]


@pytest.mark.parametrize("axial", ["biot", "green", "decoupled"])
def test_static_prestrain_sensitivity(axial):
    doc = copy.deepcopy(DOC)
    doc["members"][0]["axial"] = axial
    scene, _ = scene_from_dict(doc)
    res = solve_static(scene)
    S = StaticSensitivity(scene, res, doc)
    d = S.derivative(PATH)
    exact = np.r_[S.dx(PATH), d["potential"],
                  np.concatenate([np.asarray(d["constraint_forces"][k]) for k in sorted(d["constraint_forces"])]),
                  [d["energies"][k] for k in sorted(d["energies"])]]
    fd = richardson(static_outputs, doc, PATH)
    n, nf = len(res.x), sum(len(v) for v in res.constraint_forces.values())
    for part in (slice(0, n), slice(n, n + 1), slice(n + 1, n + 1 + nf), slice(n + 1 + nf, None)):
        assert np.linalg.norm(exact[part] - fd[part]) <= 1e-6 * np.linalg.norm(fd[part]), (axial, part)
    # the prestrain tensions the cable: the support reactions grow along the chord
    assert np.linalg.norm(d["constraint_forces"]["pin c@end"]) > 0


def test_loop_prestrain_sensitivity():
    """loops[i].prestrain: a closed ring (its last element ends on node 0) pinned at two opposite nodes, shrinking
    against them under its prestrain, and sagging: coordinates, reactions, energies and frequencies."""
    import math
    doc = {"scene": {"name": "ring", "dim": 2, "gravity": [0.0, -9.81]},
           "materials": {"m": {"E": 1e8, "density": 1200.0}}, "sections": {"s": {"area": 1e-4, "I": 1e-9}},
           "loops": [{"name": "ring", "path": [["arc", [0.0, 0.0], 0.5, 0.0, 2 * math.pi]], "elements": 16,
                      "material": "m", "section": "s", "bending": True, "prestrain": 2e-3}],
           "supports": [{"type": "pin", "member": "ring", "at": 0}, {"type": "pin", "member": "ring", "at": 8}]}
    path = "loops[0].prestrain"
    scene, _ = scene_from_dict(doc)
    res = solve_static(scene)
    S = StaticSensitivity(scene, res, doc)
    d = S.derivative(path)
    exact = np.r_[S.dx(path), d["potential"],
                  np.concatenate([np.asarray(d["constraint_forces"][k]) for k in sorted(d["constraint_forces"])]),
                  [d["energies"][k] for k in sorted(d["energies"])]]
    fd = richardson(static_outputs, doc, path)
    n, nf = len(res.x), sum(len(v) for v in res.constraint_forces.values())
    for part in (slice(0, n), slice(n, n + 1), slice(n + 1, n + 1 + nf), slice(n + 1 + nf, None)):
        assert np.linalg.norm(exact[part] - fd[part]) <= 1e-6 * np.linalg.norm(fd[part]), part
    got = np.asarray(sensitivities(doc, [path], modes=3)[path]["frequencies"])
    fdf = richardson(lambda dd: modal_analysis(scene_from_dict(dd)[0], modes=3).frequencies, doc, path)
    assert np.linalg.norm(got - fdf) <= 1e-6 * np.linalg.norm(fdf)


def test_modal_prestrain_sensitivity_frequencies_and_shapes():
    """Frequencies (the tension's change through the prestress and the mass's through the reference length) and the
    M-normalised mode shapes (Nelson), against differences of modal analyses."""
    doc = copy.deepcopy(DOC)
    modes = 3

    def run(d):
        scene, _ = scene_from_dict(d)
        return modal_analysis(scene, modes=modes)
    out = sensitivities(doc, [PATH], modes=modes)
    fd = richardson(lambda d: run(d).frequencies, doc, PATH)
    got = np.asarray(out[PATH]["frequencies"])
    assert np.linalg.norm(got - fd) <= 1e-6 * np.linalg.norm(fd), (got, fd)
    m = run(doc)
    scene, _ = scene_from_dict(doc)
    ds = ModalSensitivity(m, scene, doc).shape_derivative(PATH)
    ref = m.shapes

    def shapes(d):
        s = run(d).shapes
        return s * np.sign(np.sum(s * ref, axis=0))  # (the sign convention of each mode aligned with the reference)
    fds = richardson(shapes, doc, PATH)
    assert np.linalg.norm(ds - fds) <= 1e-6 * np.linalg.norm(fds)


def test_prestrain_refused_where_not_differentiable():
    doc = copy.deepcopy(DOC)
    doc["loads"][0]["at"] = 2.5  # a material coordinate: its element and place move with the prestrain
    scene, _ = scene_from_dict(doc)
    res = solve_static(scene)
    with pytest.raises(ParameterError, match="members\\[0\\].prestrain.*loads\\[0\\].*material coordinate"):
        StaticSensitivity(scene, res, doc).derivative(PATH)
