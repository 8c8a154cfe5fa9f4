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

from ancf_sym.elements.hermite import weights
from ancf_sym.dynamics.options import DynamicOptions
from ancf_sym.dynamics.sensors import SensorEval
from ancf_sym.system.step_system import StepSystem

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
    few percent of its run. The records of compiled chunks (`record_many`) book their energies at once (the
    energy balance can end the run) and leave the rest (sensors, constraint violation) to be evaluated for all of
    them together when the outputs are read (`t`, `data`, `viol`)."""

    def __init__(self, system: StepSystem, sensors: list[SensorEval], energies: bool = True, states: bool = False):
        self.S = system
        self._states: list | None = [] if states else None  # full coordinates per record (record_states)
        self.sensors = sensors
        self.with_energies = energies
        self._t: list[float] = []
        self._data: dict[str, list] = {s.sensor.name: [] for s in sensors}
        self._rows: list[tuple] = []  # (kinetic, potential, potentials by label..., total, works, algorithmic)
        self._viol: list[float] = []
        self._pending: list[tuple] = []  # (times, Q, V) of record_many whose sensors and violation are to come
        self.reactions: dict[str, list] = {}
        self.E0 = None
        self.scale = 0.0  # running energy scale: |T| + sum |potentials| + |works| + |E0|
        self.blowup: tuple | None = None  # (t, energy created, scale) once the scheme has created energy
        cons = system.asm.constraints  # (the violation of every support and joint, eliminated ones included)
        self._cons = None
        self._viol_fixed = 0.0  # max |Phi| of the rows on fixed coordinates only: the same at every record
        if cons.m:
            fixed = system.pos < 0
            A = cons.A.tocsr()  # (a no-op on the CSR rows the constraints hold)
            live = np.zeros(cons.m, bool)  # rows that read an unknown (linear or bilinear term)
            live[np.repeat(np.arange(cons.m), np.diff(A.indptr))[~fixed[A.indices]]] = True
            live[cons.qrow[~(fixed[cons.qi] & fixed[cons.qj])]] = True
            if live.all():
                self._cons = cons
            else:
                x = system.full(np.zeros(system.nf))
                fixed_rows = cons if not live.any() else cons.subset(np.flatnonzero(~live))
                self._viol_fixed = float(np.abs(fixed_rows.value(x)).max())
                if live.any():
                    self._cons = cons.subset(np.flatnonzero(live))
        if self._cons is not None:
            c = self._cons
            self._cA = c.A.toarray() if c.m * c.A.shape[1] <= 200_000 else c.A
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

    @property
    def t(self) -> list[float]:
        """The output times."""
        self._flush()
        return self._t

    @property
    def data(self) -> dict[str, list]:
        """The sensors' values by name, one per output time."""
        self._flush()
        return self._data

    @property
    def states(self) -> np.ndarray | None:
        """(n_outputs, n) full coordinates at the output times, or None (not asked for)."""
        self._flush()
        return None if self._states is None else np.array(self._states).reshape(len(self._t), -1)

    @property
    def viol(self) -> list[float]:
        """The constraint violation at the output times."""
        self._flush()
        return self._viol

    def record(self, t, qf, vf, damping_work, external_work, lam=None):
        self._flush()
        S = self.S
        x, v = S.full(qf), S.full_v(vf)
        if self._drives is not None and lam is not None:
            for name, val in self._drives.reactions(x, lam[S.mc - self._drives.m:]).items():
                self.reactions.setdefault(name, []).append(val)
        for s in self.sensors:
            self._data[s.sensor.name].append(s(x, v))
        if self._states is not None:
            self._states.append(x.copy())
        if self.with_energies:
            self._book(t, *S.energies_by_label(qf, vf), damping_work, external_work)
        self._viol.append(self._violation(x, t))
        self._t.append(float(t))

    def record_many(self, ts: list, Q: np.ndarray, V: np.ndarray, damping_work: float, external_work: float) -> None:
        """`record` of the output times ts with the unknowns' positions and velocities as the rows of Q and V (kept:
        not to be changed by the caller), for runs without drives (their reactions need the multipliers) and with
        the same works at all of them (a chunk of steps with nothing to integrate along them). The energies now,
        in one call of the energy graph mapped over the records; the sensors and the constraint violation when the
        outputs are read, for all the chunks' records at once: the same values as record by record (the
        violation's product summed in BLAS's order, to round-off)."""
        S = self.S
        if self.with_energies:
            for t, vals in zip(ts, S.energy_values_rows(Q, V)):
                self._book(t, *S.by_label(vals), damping_work, external_work)
        self._pending.append((ts, Q, V))

    def _flush(self) -> None:
        """The sensors and the violation of the pending records (record_many), in the order recorded."""
        if not self._pending:
            return
        blocks, self._pending = self._pending, []
        S = self.S
        Q = np.concatenate([b[1] for b in blocks]) if len(blocks) > 1 else blocks[0][1]
        V = np.concatenate([b[2] for b in blocks]) if len(blocks) > 1 else blocks[0][2]
        X, VX = S.full_rows(Q), S.full_v_rows(V)
        for s in self.sensors:
            self._data[s.sensor.name].extend([s(x, v) for x, v in zip(X, VX)])
        if self._states is not None:
            self._states.extend(np.array(X, float))
        self._viol.extend(self._violations(X))
        for ts, _, _ in blocks:
            self._t.extend(float(t) for t in ts)

    def _book(self, t, T, pots, damping_work, external_work) -> None:
        """One row of the energy balance; flags the first record where the scheme has created energy."""
        E = T + float(sum(pots))
        algorithmic = self.E0 + external_work - damping_work - E
        self._rows.append((T, E - T, *pots, E, damping_work, external_work, algorithmic))
        self.scale = max(self.scale, abs(T) + sum(map(abs, pots)) + abs(damping_work)
                         + abs(external_work) + abs(self.E0))
        created = -algorithmic
        if self.blowup is None and created > ENERGY_CREATION_LIMIT * self.scale:
            self.blowup = (float(t), created, self.scale)

    def _violation(self, x: np.ndarray, t: float) -> float:
        """max |Phi(x)| over all supports and joints (the linear rows as a small dense matrix when it is small;
        the rows on fixed coordinates only, once), and the drives' rows at time t."""
        d = self._drives
        drive = float(np.abs(d.value(x, d.w(t))).max()) if d is not None else 0.0
        cons = self._cons
        if cons is None:
            return max(self._viol_fixed, drive)
        val = self._cA @ x - cons.d
        if len(cons.qrow):
            val += np.bincount(cons.qrow, cons.qcoef * x[cons.qi] * x[cons.qj], minlength=cons.m)
        return max(float(np.abs(val).max()), self._viol_fixed, drive)

    def _violations(self, X: np.ndarray) -> list[float]:
        """_violation of each row of X (no drives)."""
        cons = self._cons
        if cons is None:
            return [self._viol_fixed] * len(X)
        if len(cons.qrow):
            return [self._violation(x, 0.0) for x in X]
        val = np.abs(self._cA @ X.T - cons.d[:, None]).max(axis=0)
        return np.maximum(val, self._viol_fixed).tolist()
