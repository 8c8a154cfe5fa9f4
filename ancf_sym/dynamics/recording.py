"""Recording a dynamic run at its output times: sensors, the energy balance and the constraint violation, with
outputs between steps from the cubic Hermite interpolant of the two step ends.

Energy bookkeeping at every output time: kinetic 1/2 v.M v, potential by label (strain energies, gravity, dead
loads, penalty joints), damping_work and external_work (booked by the time loop), and `algorithmic` = E(0) +
external_work - damping_work - (kinetic + potential): the energy the integrator itself removed (positive) or added
(negative).
"""
from __future__ import annotations

import math

import numpy as np

from ..interpolation import weights
from .options import DynamicOptions
from .sensors import SensorEval
from .step_system import StepSystem

# The alpha schemes dissipate (or, Newmark, conserve to O(h^2)); a run whose energy balance shows the scheme
# *creating* more than this fraction of the energy scale has gone unstable (Newton can still "converge" every step
# of a blow-up, e.g. a 10 N step load on a soft string at dt = 1e-4): it stops with status energy_blowup.
ENERGY_CREATION_LIMIT = 0.1
DEFAULT_OUTPUTS = 200  # output intervals when none of output_every, output_dt, output_times is given


def output_grid(opts: DynamicOptions) -> np.ndarray | None:
    """The output times asked for (output_times, or every output_dt); None: every output_every steps."""
    if opts.output_times is not None:
        return np.asarray(opts.output_times, float)
    if opts.output_dt is not None:
        n = int(math.floor((opts.t_end - opts.t_start) / opts.output_dt + 1e-9))
        ts = opts.t_start + opts.output_dt * np.arange(n + 1)
        if opts.t_end - ts[-1] > 1e-9 * opts.output_dt:
            ts = np.r_[ts, opts.t_end]
        return ts
    return None


def hermite(t0, t1, q0, v0, q1, v1, tau):
    """q and q' at tau of the cubic through (q0, v0) at t0 and (q1, v1) at t1: interpolation.weights in time."""
    w, wx, _ = weights((tau - t0) / (t1 - t0), t1 - t0)
    return w[0] * q0 + w[1] * v0 + w[2] * q1 + w[3] * v1, wx[0] * q0 + wx[1] * v0 + wx[2] * q1 + wx[3] * v1


class Recorder:
    """The outputs of a run, one record per output time (see the module docstring). The energies are kept as one
    row per record and returned as columns (`energies`): a record costs ~30 -> ~15 us on a 32-element rope, a
    few percent of its run."""

    def __init__(self, system: StepSystem, sensors: list[SensorEval], energies: bool = True):
        self.S = system
        self.sensors = sensors
        self.with_energies = energies
        self.t: list[float] = []
        self.data: dict[str, list] = {s.sensor.name: [] for s in sensors}
        self._rows: list[tuple] = []  # (kinetic, potential, potentials by label..., total, works, algorithmic)
        self.viol: list[float] = []
        self.reactions: dict[str, list] = {}
        self.E0 = None
        self.scale = 0.0  # running energy scale: |T| + sum |potentials| + |works| + |E0|
        self.blowup: tuple | None = None  # (t, energy created, scale) once the scheme has created energy
        cons = system.asm.constraints  # (the violation of every support and joint, eliminated ones included)
        self._cons = cons if cons.m else None
        if self._cons is not None:
            self._cA = cons.A.toarray() if cons.m * cons.A.shape[1] <= 200_000 else cons.A
        d = system.drives
        self._drives = d if d is not None and d.m else None

    @property
    def energies(self) -> dict[str, list]:
        """The energy columns: kinetic, potential, potential_<label> per label, total, damping_work,
        external_work, algorithmic (empty without energies or records)."""
        if not self._rows:
            return {}
        keys = ("kinetic", "potential", *(f"potential_{k}" for k in self.S.potential_labels), "total",
                "damping_work", "external_work", "algorithmic")
        return {k: list(col) for k, col in zip(keys, zip(*self._rows))}

    def energy(self, qf, vf):
        T, pot = self.S.energies(qf, vf)
        return T, pot, T + float(sum(pot.values()))

    def record(self, t, qf, vf, damping_work, external_work, lam=None):
        S = self.S
        x, v = S.full(qf), S.full_v(vf)
        if self._drives is not None and lam is not None:
            for name, val in self._drives.reactions(x, lam[S.mc - self._drives.m:]).items():
                self.reactions.setdefault(name, []).append(val)
        for s in self.sensors:
            self.data[s.sensor.name].append(s(x, v))
        if self.with_energies:
            T, pots = self.S.energies_by_label(qf, vf)
            E = T + float(sum(pots))
            algorithmic = self.E0 + external_work - damping_work - E
            self._rows.append((T, E - T, *pots, E, damping_work, external_work, algorithmic))
            self.scale = max(self.scale, abs(T) + sum(map(abs, pots)) + abs(damping_work)
                             + abs(external_work) + abs(self.E0))
            created = -algorithmic
            if self.blowup is None and created > ENERGY_CREATION_LIMIT * self.scale:
                self.blowup = (float(t), created, self.scale)
        self.viol.append(self._violation(x, t))
        self.t.append(float(t))

    def _violation(self, x: np.ndarray, t: float) -> float:
        """max |Phi(x)| over all supports and joints (the linear rows as a small dense matrix when it is small),
        and the drives' rows at time t."""
        d = self._drives
        drive = float(np.abs(d.value(x, d.w(t))).max()) if d is not None else 0.0
        cons = self._cons
        if cons is None:
            return drive
        val = self._cA @ x - cons.d
        if len(cons.qrow):
            val += np.bincount(cons.qrow, cons.qcoef * x[cons.qi] * x[cons.qj], minlength=cons.m)
        return max(float(np.abs(val).max()), drive)
