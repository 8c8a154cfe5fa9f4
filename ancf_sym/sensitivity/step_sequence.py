"""Runs of the alpha schemes for the sensitivities with steps of varying size: the adaptive run's accepted steps
(the package's time loop, its error control and rejections, each accepted state kept), or a given sequence of steps
held (every step taken as given: to re-run a changed scene on the same steps, or a fixed-step run's shorter last
step).

The sensitivities of such a run are those of its accepted steps held: the step sizes chosen by the error control
depend on the parameters too, but that dependence is not differentiated (the usual choice of adjoint and forward
sensitivity solvers for adaptive integrators, e.g. CVODES and FATODE): the derivative is that of the discrete
solution on these steps, which differences of runs on the same steps reproduce; differences of freely adaptive runs
differ from it by the change of the step sequence (of the order of the error tolerance over the parameter step).
"""
from __future__ import annotations

from typing import Callable

import numpy as np

from ancf_sym.dynamics import DynamicOptions
from ancf_sym.dynamics.recording import Recorder
from ancf_sym.dynamics.time_loads import LoadSum
from ancf_sym.dynamics.time_loop import TimeLoop
from ancf_sym.scene.builder import SceneError
from ancf_sym.system.step_system import StepSystem


def adaptive_steps(S: StepSystem, integ, opts: DynamicOptions, loads: LoadSum | None,
                   row: Callable[[], np.ndarray]) -> tuple[list, np.ndarray]:
    """(rows, h): row() of the integrator after each accepted step of the adaptive run (the start's first), and the
    accepted step sizes, from the package's time loop with the run's own limits (dt_min, dt_max, tol)."""
    rows, hs, ts = [row()], [], [opts.t_start]

    def keep(t_new: float) -> None:
        rows.append(row())
        # (the step just accepted as the alpha integrator took it; collocation keeps no h: t_new - t, within an
        # ulp of t)
        hs.append(integ.h_prev if hasattr(integ, "h_prev") else t_new - ts[-1])
        ts.append(t_new)
    dt_min = opts.dt_min or opts.dt * 2.0 ** -12  # (the run's defaults: ancf_sym.dynamics.run.simulate)
    dt_max = opts.dt_max or opts.dt * 100
    err_tol = opts.tol or 1e-6 * S.length_scale
    loop = TimeLoop(S, integ, opts, loads, Recorder(S, [], False), np.array([opts.t_end]), None, None, dt_min,
                    dt_max, err_tol)
    loop.on_step = keep
    loop.go()
    if loop.status != "completed":
        raise SceneError(f"dynamic sensitivities: the adaptive run ended with {loop.status} ({loop.message})")
    return rows, np.array(hs)


def held_steps(integ, t_start: float, steps: np.ndarray, loads: LoadSum | None, row: Callable[[], np.ndarray]
               ) -> list:
    """row() after each of the given steps, taken one by one as given (the start's first); a step whose Newton
    iteration fails is an error (held steps cannot be shortened)."""
    rows = [row()]
    t = t_start
    for h in np.asarray(steps, float):
        out = integ.attempt(t, float(h), loads)
        if not out.converged:
            raise SceneError(f"dynamic sensitivities: the held step t = {t:.6g} s, h = {h:.6g} s did not converge "
                             f"({out.reason})")
        integ.accept()
        rows.append(row())
        t = t + float(h)
    return rows


def step_notes(run) -> list[str]:
    """What the derivative of an adaptive run (an alpha_run.AlphaRun) holds fixed: its accepted steps."""
    if not run.options.adaptive or run.H is None:
        return []
    return [f"adaptive steps: the derivative of the run on its {len(run.H)} accepted steps held (h from "
            f"{run.H.min():.3g} to {run.H.max():.3g} s); the step sizes' dependence on the parameters through the "
            "error control is not differentiated"]
