"""Modal analysis about the static equilibrium: statics first (the prestress of gravity, loads, prestrain,
contacts), then the lowest eigenpairs of the exact Hessian of the Lagrangian and the mass matrix on the reduced
coordinates, the remaining exact constraints eliminated (ancf_sym.modal.eigen). User guide: docs/modal.md."""
from __future__ import annotations

import time

import numpy as np

from ancf_sym.scene.builder import Scene, SceneError
from ancf_sym.scene.schema import MODAL_OPTIONS
from ancf_sym.statics.problem import StaticOptions, StaticProblem, StaticResult, problem_for
from ancf_sym.modal.eigen import REAL_REL, ZERO_REL, damped_modes, lowest_modes, stiffness_scale
from ancf_sym.modal.linearize import linearize
from ancf_sym.modal.result import DampedModes, ModalResult


def check_modes(modes) -> int:
    return int(MODAL_OPTIONS["modes"].check("modes", modes))


def frequencies_of(w2: np.ndarray, zero: np.ndarray) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
    """(Re w^2, Im w^2 or None where all are real, frequencies [Hz]): sqrt(w^2) / 2 pi, -sqrt(-w^2) / 2 pi for an
    unstable mode, 0 for a zero one; a complex w^2 (an unsymmetric K: a current's drag) Re sqrt(w^2) / 2 pi (its
    pair grows and decays at |Im sqrt(w^2)|)."""
    w2 = np.asarray(w2)
    if not np.iscomplexobj(w2):
        return w2, None, np.where(zero, 0.0, np.sign(w2) * np.sqrt(np.abs(w2)) / (2 * np.pi))
    cplx = np.abs(w2.imag) > REAL_REL * np.abs(w2)  # (the rest: real to Arnoldi's round-off)
    real = np.sign(w2.real) * np.sqrt(np.abs(w2.real))
    return w2.real, w2.imag, np.where(zero, 0.0, np.where(cplx, np.sqrt(w2).real, real) / (2 * np.pi))


def modal_analysis(scene: Scene, modes: int = 10, static: StaticResult | None = None,
                   options: StaticOptions | None = None, damped: bool = False, **static_options) -> ModalResult:
    """The `modes` lowest natural modes of a scene about its static equilibrium.

    static: an equilibrium already solved for this scene (else solved here with `options` or keyword StaticOptions
    fields). A failed static solve gives a result with success False, its status and no modes. damped: also the
    complex eigenvalues of the damped system (the scene's damping, linearize's D): result.damped. A scene in water:
    about its statics in water, with the added mass, the buoyancy and the current's drag (its load stiffness makes
    K unsymmetric: see result.omega2_imag; damped=True adds the drag's damping), ancf_sym.modal.water."""
    modes = check_modes(modes)
    damped = bool(MODAL_OPTIONS["damped"].check("damped", damped))
    water = getattr(scene, "water", None)
    if water is not None and water.waves is not None:  # a time-dependent load has no place in a linearisation
        raise SceneError("water.waves: modal analysis linearises about the statics' equilibrium (current only); "
                         "remove the waves for a modal analysis, run the dynamics for the response to them")
    t0 = time.perf_counter()
    try:
        prob = problem_for(scene)
    except SceneError as err:  # a free structure? Its modes about the unloaded reference (rigid ones at zero)
        scene.validate_for_statics(allow_free=True)  # (anything else wrong: raised here)
        prob = StaticProblem(scene)
        if not prob.unloaded_at_rest(prob.asm.x0):
            raise SceneError(f"{err}; a free structure has modes about its unloaded reference only (no gravity, "
                             "loads or prestrain): support it, or remove them") from None
    part = prob.S.part  # (the statics' ReducedModel)
    free = part.ny - len(part.rows)
    if modes > free:
        raise SceneError(f"modes = {modes} exceeds the {free} degrees of freedom the supports and joints leave")
    if static is None:
        static = prob.solve(options or (StaticOptions(**static_options) if static_options else None))
    elif static.assembly is None or static.x.shape != (prob.asm.n,):
        raise SceneError("modal_analysis: static is not a result of this scene")
    if not static.success:
        n = prob.asm.n
        return ModalResult(f"static: {static.status}", False, np.zeros(0), np.zeros(0), np.zeros(0, bool),
                           np.zeros((n, 0)), [], static, wall_s=time.perf_counter() - t0)
    lin = linearize(scene, static, damping_matrix=damped, problem=prob)
    w2, Y, method = lowest_modes(lin.K, lin.M, lin.G, modes)
    zero = np.abs(w2) <= ZERO_REL * stiffness_scale(lin.K, lin.M)
    w2, w2_imag, freq = frequencies_of(w2, zero)
    shapes = lin.full(Y.real)  # (an unsymmetric K's complex modes: their real parts)
    dim = prob.asm.scene.dim
    # the position coordinates: member nodes and body centres (bodies: the centre first in their coordinates)
    pos = np.concatenate([mm.offset + (np.arange(mm.n_nodes)[:, None] * mm.node_size + np.arange(dim)).ravel()
                          for mm in prob.asm.mesh.members.values()] +
                         [off + np.arange(dim) for off in prob.asm.mesh.bodies.values()] + [np.zeros(0, int)])
    umax = np.max(np.abs(shapes[pos]), axis=0) if len(pos) else np.zeros(len(w2))
    masses = [float(1.0 / u ** 2) if u > 0 else None for u in umax]
    status = "Solve_Succeeded" if np.all(np.isfinite(w2)) else "Eigen_Solve_Failed"
    complex_modes = None
    if damped and status == "Solve_Succeeded":
        D = lin.D if lin.D is not None else 0.0 * lin.M
        # the shift: below the lowest mode (a tenth of its undamped w), where the pencil is regular
        w_low = np.sqrt(np.abs(w2[~zero])).min() if np.any(~zero) else np.sqrt(stiffness_scale(lin.K, lin.M)) * 1e-3
        # a zero (rigid) mode is a double root lambda = 0 (and -alpha with mass-proportional damping): its pair
        # comes out as round-off; reported as one exact 0 per zero mode, the rest after them
        nz = int(np.sum(zero))
        lam = damped_modes(lin.K, lin.M, D, lin.G, modes + nz, -0.1 * float(w_low))
        tiny = np.abs(lam) ** 2 <= ZERO_REL * stiffness_scale(lin.K, lin.M)
        lam = np.r_[np.zeros(nz, complex), lam[~tiny]][:modes]
        complex_modes = DampedModes(lam)
    return ModalResult(status, status == "Solve_Succeeded", w2, freq, zero, shapes, masses, static, method,
                       time.perf_counter() - t0, lin, complex_modes, w2_imag)
