"""The kink Newton without an option: a scene with a linear-law contact gets the line search (and the iteration
budget such steps need) by itself; other scenes and explicit choices keep theirs."""
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "examples"))
import belt_drive as BD  # noqa: E402

from ancf_sym.dynamics import DynamicOptions, NewtonOptions, simulate  # noqa: E402
from ancf_sym.dynamics.newton import KINK_MAX_ITER, resolve_kinks  # noqa: E402
from ancf_sym.model.assembly import Assembly  # noqa: E402

K_N, N_EL, R2 = 1e8, 48, 0.15  # the bench's belt on Exudyn's linear law


def test_linear_law_belt_needs_no_newton_option():
    """Default options on the linear-law belt through 0.2 s: no rejected step (plain full Newton rejected thousands
    of sub-steps here, ~80 s, tests/contact/test_contact_kink_newton.py)."""
    asm = Assembly(BD.scene(R2, 20.0, 20.0, N_EL, k_n=K_N))
    opts = DynamicOptions(dt=1e-3, t_end=0.2, integrator="generalized_alpha", rho_inf=0.6, output_dt=0.01,
                          energies=False, q0=BD.start(asm, R2, N_EL, K_N))
    r = simulate(asm, opts)
    assert r.success, r.status
    assert len(r.rejected) == 0, r.rejected[:3]


def test_resolution_keeps_explicit_choices():
    auto = NewtonOptions()
    on = resolve_kinks(auto, True)
    assert on.line_search is True and on.max_iter == KINK_MAX_ITER
    assert resolve_kinks(NewtonOptions(max_iter=50), True).max_iter == 50  # a larger budget is kept
    assert resolve_kinks(auto, False).line_search is False and resolve_kinks(auto, False).max_iter == auto.max_iter
    off = resolve_kinks(NewtonOptions(line_search=False), True)
    assert off.line_search is False and off.max_iter == auto.max_iter
