"""Static equilibrium by minimising the total potential: `problem` (StaticProblem, solve_static, StaticResult: Newton
first, load steps and IPOPT where Newton alone is not enough), `newton` and `newton_loop` (the Newton on the kernels,
in Python and in C), `criteria` (what it calls converged), `evaluation` (the reduced energy, gradient and banded
tangent), `coarse` (a coarser mesh's answer as a start), `contact` (exact contact by IPOPT with second-order
checks), `inertia` (stability)."""
from ancf_sym.statics.problem import (BIOT_MAX_ITER, BIOT_TOL, INTERRUPTED, SUCCESS, TUNNELLED, StaticOptions,
                                      StaticProblem, StaticResult, problem_for, solve_static)

__all__ = ["BIOT_MAX_ITER", "BIOT_TOL", "INTERRUPTED", "SUCCESS", "TUNNELLED", "StaticOptions", "StaticProblem",
           "StaticResult", "problem_for", "solve_static"]
