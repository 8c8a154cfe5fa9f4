"""Many steps in one compiled call: a step function mapped over a chunk of steps, and the guarded step that
ends a chunk at the first step it cannot accept.

A guarded step carries a 'failed' flag in its state: a step the graph cannot accept (not converged, or a
non-finite state) sets it, and every later step of the chunk is a no-op that passes the state on (a switch that
evaluates only the branch taken), so a chunk costs the steps it accepts plus one.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

LARGE_STATE = 2000  # step states of this size or more: guarded from the start, chunks run step by step (alpha)


def map_steps(step: ca.Function, n: int, n_accum: int) -> ca.Function:
    """n steps in one function: step.mapaccum(n, n_accum), the first n_accum inputs carried from step to step,
    the others given per step as columns; the outputs of every step as columns. Unrolled (one call node per
    step, option base -1): on a 130-unknown rope 1.1 ms to build against 3.1 ms for mapaccum's default tower of
    nested 10-step loops, and as fast to evaluate. (Large states build no chunk graph: AlphaIntegrator calls
    their step once per step; an unrolled 50-step graph took 0.1-0.15 s to build at 1000 elements.)"""
    return step.mapaccum(f"alpha_steps_{n}", n, n_accum, {"base": -1})


def guarded(f: ca.Function, state_size: int, n_accum: int, info_size: int) -> ca.Function:
    """The step function f with a 'failed' flag appended to its state (see the module docstring); its info's
    first entry is 1 for a step that converged with a finite state."""
    ins = [ca.MX.sym(f.name_in(i), f.sparsity_in(i)) for i in range(f.n_in())]
    st = ca.MX.sym("state", state_size + 1)
    outs = f(st[:state_size], *ins[1:])
    new, info = outs[0], outs[-1]
    finite = ca.fabs(ca.sum1(ca.vertcat(new, *outs[1:-1]))) < np.inf  # (false for NaN and inf)
    failed = ca.logic_not(ca.logic_and(info[0] == 1, finite))
    info = ca.vertcat(ca.logic_not(failed), info[1:])  # ok = converged and finite
    names = (["state"] + [f.name_in(i) for i in range(1, f.n_in())],
             ["next_state"] + [f.name_out(i) for i in range(1, f.n_out())])
    run = ca.Function("step", [st] + ins[1:], [ca.vertcat(new, failed)] + list(outs[1:-1]) + [info])
    keep = ca.Function("skip", [st] + ins[1:], [st] + ins[1:n_accum] + [ca.DM.zeros(info_size)])
    g = ca.Function.conditional("guarded_step", [run], keep)  # flag 0: the step; 1: no-op
    return ca.Function("alpha_step_guarded", [st] + ins[1:], g(st[-1], st, *ins[1:]), *names)
