"""Dynamic sensitivities at a run's output times: where an output time falls inside a step (adaptive steps, an
output_dt off the step grid) the run records the cubic Hermite interpolant of the step's end states (q, v at both
ends, ancf_sym.dynamics.recording.hermite); that interpolant is linear in the states for fixed times, so the
sensitivities interpolated with the same weights are its exact derivative. Multipliers are interpolated linearly,
as the run interpolates them."""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from ancf_sym.dynamics.recording import hermite
from ancf_sym.sensitivity.dynamics import DynamicSensitivity


def at_times(ds: DynamicSensitivity, times: np.ndarray, eps_t: float) -> DynamicSensitivity:
    """ds at `times` (within the run's span): a step's end state where a time is that step's end (within eps_t, as
    the time loop decides), else the Hermite interpolant over the step that holds it, the derivatives alike."""
    t = ds.t
    times = np.asarray(times, float)
    j = np.clip(np.searchsorted(t, times - eps_t), 0, len(t) - 1)  # (the first step end at or after each time)
    rows: list[tuple] = []
    for tau, k in zip(times, j):
        if abs(t[k] - tau) <= eps_t or k == 0:
            rows.append((k, None))
        else:
            rows.append((k, tau))

    def states(x: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        xo, vo = np.empty((len(rows), x.shape[1])), np.empty((len(rows), v.shape[1]))
        for i, (k, tau) in enumerate(rows):
            if tau is None:
                xo[i], vo[i] = x[k], v[k]
            else:
                xo[i], vo[i] = hermite(t[k - 1], t[k], x[k - 1], v[k - 1], x[k], v[k], tau)
        return xo, vo

    def linear(y: np.ndarray) -> np.ndarray:
        out = np.empty((len(rows),) + y.shape[1:])
        for i, (k, tau) in enumerate(rows):
            out[i] = y[k] if tau is None else y[k - 1] + (tau - t[k - 1]) / (t[k] - t[k - 1]) * (y[k] - y[k - 1])
        return out
    x, v = states(ds.x, ds.v)
    dx, dv = {}, {}
    for p in ds.dx:
        dx[p], dv[p] = states(ds.dx[p], ds.dv[p])
    lam = linear(ds.lam) if ds.lam is not None and ds.lam.size else ds.lam
    dlam = {p: linear(d) for p, d in ds.dlam.items() if d.size} if ds.dlam else ds.dlam
    return replace(ds, t=times, x=x, v=v, dx=dx, dv=dv, lam=lam, dlam=dlam)
