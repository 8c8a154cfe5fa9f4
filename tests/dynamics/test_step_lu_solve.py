"""The time steps' linear solve: sparse LU (CSparse, threshold partial pivoting) where the step matrix has multiplier
rows or is unsymmetric (linsol "auto_lu", what simulate builds), sparse QR for statics ("auto"), LDL^T where the
matrix is symmetric positive definite. Checked on the belt drive (a closed belt with friction on two body-carried
pulleys, a drive row and a torque: unsymmetric, with multipliers) at a mid-run state."""
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "examples"))
import belt_drive as BD  # noqa: E402

from ancf_sym import Material, Scene, Section  # noqa: E402
from ancf_sym.dynamics.schemes import Scheme  # noqa: E402
from ancf_sym.model.assembly import Assembly  # noqa: E402
from ancf_sym.system.step_system import StepSystem  # noqa: E402

N_EL, R2, DT = 16, 0.15, 1e-3


def _system(asm: Assembly, linsol: str) -> StepSystem:
    S = StepSystem.for_scene(asm, linsol=linsol)
    S.x[:] = S.reduce(BD.start(asm, R2, N_EL))
    S.p[S.nf:] = S.w(0.3)  # the drives' time inputs mid-run (all zero would leave the driven angle's row zero)
    sc = Scheme.generalized_alpha(0.6)
    S.cm[0], S.cc[0], S.kc[0] = sc.cm(DT), sc.cc(DT), sc.cm(DT) * S.stiffness_scale()
    return S


@pytest.fixture(scope="module")
def belt():
    return Assembly(BD.scene(R2, 20.0, 20.0, N_EL))


def test_lu_and_qr_give_the_same_newton_update(belt):
    """The LU's update solves the same KKT system as QR's: both are backward stable here (the step matrix carries
    cm M on its diagonal), so they differ by at most ~cond(KKT) x eps relative (a factor 10 for the sums); a wrong
    pivot order or a dropped row would differ at O(1)."""
    lu, qr = _system(belt, "auto_lu"), _system(belt, "auto")
    assert (lu.linsol, qr.linsol) == ("csparse", "qr")
    dz_lu, dz_qr = lu.iterate().copy(), qr.iterate().copy()
    K = qr.jacobian().toarray()
    cond = np.linalg.cond(K)
    assert np.isfinite(dz_lu).all()
    assert np.abs(dz_lu - dz_qr).max() <= 10 * cond * np.finfo(float).eps * np.abs(dz_qr).max()
    # and it solves the system: the residual of K dz = -r to the same bound
    res = K @ dz_lu + qr.r
    assert np.abs(res).max() <= 10 * cond * np.finfo(float).eps * np.abs(qr.r).max()


def test_symmetric_positive_definite_steps_keep_ldl():
    """A pinned cable without multipliers or unsymmetric terms: LDL^T either way (auto_lu changes only QR's cases)."""
    sc = Scene(dim=2, gravity=(0.0, -9.81))
    sc.member("c", [(0, 0), (1, 0)], 4, Material(E=1e9, density=1000), Section.circle(0.005))
    sc.pin("c", "start")
    S = StepSystem.for_scene(Assembly(sc), linsol="auto_lu")
    assert S.mc == 0 and S.linsol == "ldl"


def test_exactly_singular_step_matrix_is_a_failed_newton_not_an_error(belt):
    """With the drives' time inputs all zero the driven angle's row (sin, cos of the prescribed angle) is zero: the
    step matrix is exactly singular, which the LU refuses; Newton reports it as a failed solve (the step is then
    rejected and the run ends with its status), it does not raise."""
    from ancf_sym.dynamics.newton import Counters, Factor, NewtonOptions, newton

    S = _system(belt, "auto_lu")
    S.p[S.nf:] = 0.0
    with pytest.raises(RuntimeError):  # (the LU's own refusal, which newton turns into an outcome)
        S.iterate()
    out = newton(S, Factor(), None, NewtonOptions(modified=False), Counters(), 1e-6, 1e-9)
    assert not out.converged and out.reason == "singular iteration matrix"
