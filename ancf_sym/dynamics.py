"""Dynamics of a scene: M q'' + C q' + grad U(q) + J^T lam = Q(t), Phi(q) = 0, by implicit integration.

    res = run_dynamics(scene, {"integrator": "generalized_alpha", "dt": 1e-3, "t_end": 2.0, "rho_inf": 0.9,
                               "output_dt": 0.01,
                               "sensors": [{"name": "tip", "kind": "position", "member": "beam", "at": "end"}]})
    res.t, res.sensors["tip"], res.energies["kinetic"], res.status

Integrators: "newmark" (beta, gamma), "hht" (alpha in [-1/3, 0]), "generalized_alpha" (rho_inf) from
ancf_sym.integrators; "radau" and "gauss" (collocation, `stages`) from ancf_sym.collocation. Fixed step by
default; `adaptive` controls the local error estimate against `tol` [m]. A step whose Newton iteration fails is
rejected and retried with half the step (recorded in `rejected`); the run ends with status "newton_failed" at
the last good state when the step would fall below dt_min. Results never contain NaN.

Energy bookkeeping at every output time: kinetic 1/2 v.M v, potential by label (strain energies, gravity, dead
loads, penalty joints), damping_work (work done against the damping forces) and external_work (of time-dependent
loads), both as the work of the forces of the discrete equations along each step, dq.(f_n + f_n+1)/2 (exact in the
energy identity of trapezoidal Newmark), and `algorithmic` = E(0) + external_work - damping_work - (kinetic +
potential): the energy the integrator itself removed (positive) or added (negative).
"""
from __future__ import annotations

import math
import re
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np
import scipy.sparse as sp

from . import bodies, contact, spatial_bodies
from . import initial as initial_state
from .assembly import Assembly
from .interpolation import Probe, weights
from .integrators import (LINEAR_EFFECTS, AlphaIntegrator, Counters, NewtonOptions, RayleighData, Scheme,
                          StepSystem, StrainRateData)
from .mesh import check_stretch
from .checks import check_fields, check_keys, fail, number
from .scene import Scene, SceneError
from .schema import DYNAMIC_OPTIONS

INTEGRATORS = {"newmark": "newmark", "hht": "hht", "hht_alpha": "hht", "generalized_alpha": "generalized_alpha",
               "generalized-alpha": "generalized_alpha", "genalpha": "generalized_alpha",
               "gen_alpha": "generalized_alpha", "radau": "radau", "radau_iia": "radau", "radauiia": "radau",
               "gauss": "gauss", "gauss_legendre": "gauss", "gauss-legendre": "gauss"}
SENSOR_KINDS = ("position", "displacement", "velocity", "strain", "curvature", "coordinates", "body")


def _pos(name: str, value: Any, allow_zero: bool = False) -> float:
    return number(name, value, positive=not allow_zero, nonneg=allow_zero)


_num = number


# -- sensors -----------------------------------------------------------------------------------------------------

@dataclass
class Sensor:
    """What to record at output times.

    kind: "position" | "displacement" (from the reference) | "velocity" of a centreline point;
    "strain" (|r_x| - 1) | "curvature" (|r_x x r_xx| / |r_x|^3) at a point; "coordinates" (all nodal
    coordinates of a node); "body": a rigid body's (x, y, angle, angular velocity), `member` naming the body
    (spatial: centre (3), angular velocity (3, world), axes e1, e2, e3 (9), ancf_sym.spatial_bodies.sensor).
    member and at ("start", "end", node index or material coordinate s [m]) name the
    point. Energies and the constraint violation are always recorded.
    """
    name: str
    kind: str
    member: str
    at: Any = "end"

    @classmethod
    def from_dict(cls, d: dict, index: int) -> "Sensor":
        if isinstance(d, Sensor):
            return d
        if not isinstance(d, dict):
            raise SceneError(f"sensors[{index}] must be a table with kind, member, at; got {d!r}")
        unknown = set(d) - {"name", "kind", "member", "at"}
        if unknown:
            raise SceneError(f"sensors[{index}]: unknown field(s) {sorted(unknown)}; known: name, kind, member, at")
        kind = d.get("kind")
        if kind not in SENSOR_KINDS:
            raise fail(f"sensors[{index}].kind", f"must be one of {' | '.join(SENSOR_KINDS)}", kind)
        member = d.get("member")
        at = d.get("at", "end")
        name = d.get("name") or f"{kind}_{member}_{at}"
        return cls(str(name), kind, member, at)


class _SensorEval:
    def __init__(self, sensor: Sensor, asm: Assembly, index: int):
        scene = asm.scene
        self.sensor = sensor
        if sensor.kind == "body":
            if sensor.member not in asm.mesh.bodies:
                raise SceneError(f"sensors[{index}].member={sensor.member!r} names no body; bodies: "
                                 f"{sorted(asm.mesh.bodies)}")
            self.offset = asm.mesh.bodies[sensor.member]
            self.spatial = scene.dim == 3
            return
        if sensor.member not in asm.mesh.members:
            raise SceneError(f"sensors[{index}].member={sensor.member!r} names no member; members: "
                             f"{sorted(asm.mesh.members)}")
        try:
            scene.check_at(sensor.member, sensor.at, node_only=sensor.kind == "coordinates",
                            field_name=f"sensors[{index}].at")
        except SceneError:
            raise
        mm = asm.mesh.members[sensor.member]
        self.sensor, self.mm, self.dim = sensor, mm, scene.dim
        if sensor.kind == "coordinates":
            self.dofs = mm.node_dofs(mm.node(sensor.at))
            self.probe = None
        else:
            self.probe = Probe(mm, mm.coordinate(sensor.at), scene.dim)
            self.r0 = self.probe.r(asm.x0)

    def __call__(self, x: np.ndarray, v: np.ndarray) -> np.ndarray:
        k = self.sensor.kind
        if k == "body":  # angular velocity c s_dot - s c_dot of the unit vector (c, s)
            o = self.offset
            if self.spatial:
                return spatial_bodies.sensor(x, v, o)
            return np.array([*bodies.state(x, o), x[o + 2] * v[o + 3] - x[o + 3] * v[o + 2]])
        p = self.probe
        if k == "coordinates":
            return x[self.dofs].copy()
        if k == "position":
            return p.r(x)
        if k == "displacement":
            return p.r(x) - self.r0
        if k == "velocity":
            return p.r(v)
        rx = p.rx(x)
        nrm = float(np.linalg.norm(rx))
        if k == "strain":
            return np.array([nrm - 1.0])
        rxx = p.rxx(x)
        if self.dim == 2:
            c = abs(float(rx[0] * rxx[1] - rx[1] * rxx[0]))
        else:
            c = float(np.linalg.norm(np.cross(rx, rxx)))
        return np.array([c / max(nrm, 1e-300) ** 3])


# -- time-dependent loads ----------------------------------------------------------------------------------------

@dataclass
class TimeLoad:
    """A point force F(t) = factor(t) * force at a node or material coordinate, factor piecewise linear in
    `history` [(t, factor), ...] (zero outside unless the first/last factor says otherwise: held constant)."""
    member: str
    at: Any
    force: Sequence[float]
    history: Sequence[Sequence[float]]

    @classmethod
    def from_dict(cls, d: dict, index: int) -> "TimeLoad":
        if isinstance(d, TimeLoad):
            return d
        if not isinstance(d, dict):
            raise SceneError(f"loads[{index}] must be a table with member, at, force, history; got {d!r}")
        unknown = set(d) - {"member", "at", "force", "history"}
        missing = {"member", "force", "history"} - set(d)
        if unknown or missing:
            raise SceneError(f"loads[{index}]: unknown {sorted(unknown)} / missing {sorted(missing)} fields; "
                             "expected member, at, force, history")
        return cls(d["member"], d.get("at", "end"), d["force"], d["history"])


class _LoadSum:
    def __init__(self, loads: list[TimeLoad], asm: Assembly, free: np.ndarray):
        from .loads import point_force
        from .scene import _vector
        self.vecs, self.hist = [], []
        for i, ld in enumerate(loads):
            asm.scene.check_at(ld.member, ld.at, node_only=False, field_name=f"loads[{i}].at")
            F = _vector(f"loads[{i}].force", ld.force, asm.scene.dim)
            try:
                H = np.asarray(ld.history, dtype=float)
            except (TypeError, ValueError):
                raise SceneError(f"loads[{i}].history must be a list of [t, factor] pairs, got {ld.history!r}") from None
            if H.ndim != 2 or H.shape[1] != 2 or len(H) < 1 or not np.all(np.isfinite(H)) or np.any(np.diff(H[:, 0]) <= 0):
                raise SceneError(f"loads[{i}].history must be [t, factor] pairs with increasing finite times, got "
                                 f"{ld.history!r}")
            mm = asm.mesh.members[ld.member]
            idx, val = point_force(mm, mm.coordinate(ld.at), F)
            q = np.zeros(asm.n)
            np.add.at(q, idx, val)
            self.vecs.append(free.T @ q)
            self.hist.append(H)

    def __call__(self, t: float) -> np.ndarray:
        out = np.zeros_like(self.vecs[0])
        for q, H in zip(self.vecs, self.hist):
            out += np.interp(t, H[:, 0], H[:, 1]) * q
        return out


# -- options and result ------------------------------------------------------------------------------------------

@dataclass
class DynamicOptions:
    dt: float
    t_end: float
    integrator: str = "generalized_alpha"
    t_start: float = 0.0
    rho_inf: float = 0.9  # generalized-alpha spectral radius at infinite frequency
    alpha: float = -0.05  # HHT
    beta: float = 0.25  # Newmark
    gamma: float = 0.5  # Newmark
    stages: int | None = None  # collocation stages (radau default 3, gauss default 2)
    adaptive: bool = False
    tol: float | None = None  # adaptive: local error tolerance [m] (default 1e-6 x length scale)
    dt_min: float | None = None  # smallest step before giving up (default dt * 2^-12)
    dt_max: float | None = None  # adaptive: largest step (default 100 dt... but at most the output spacing)
    output_every: int | None = None  # record every k accepted steps (fixed step); default: ~200 outputs
    output_dt: float | None = None  # record at t_start + k output_dt
    output_times: Sequence[float] | None = None  # record at these times
    newton: NewtonOptions = field(default_factory=NewtonOptions)
    sensors: list = field(default_factory=list)
    loads: list = field(default_factory=list)  # TimeLoad (time-dependent point forces)
    energies: bool = True  # record the energy balance at output times (one energy evaluation per output)
    q0: np.ndarray | None = None  # initial coordinates (full, default the reference state)
    v0: np.ndarray | None = None  # initial velocities (full, default zero)
    initial: list | None = None  # initial velocities per member/body ([[initial]] tables, ancf_sym.initial)
    start: str | None = None  # "reference" (default) | "static": start from the static equilibrium

    def __post_init__(self):
        check_fields(self, DYNAMIC_OPTIONS, "analysis")  # types and ranges as declared in ancf_sym.schema
        if self.initial is not None:
            self.initial = initial_state.check_specs(self.initial)
            if self.v0 is not None:
                raise fail("analysis.initial", "and v0 both give the initial velocities: give one", self.initial)
        if self.start == "static" and self.q0 is not None:
            raise fail("analysis.start", "= 'static' and q0 both give the initial state: give one", self.start)
        if self.t_end <= self.t_start:
            raise fail("analysis.t_end", f"must be greater than t_start = {self.t_start:g}", self.t_end)
        if self.dt > self.t_end - self.t_start:
            raise fail("analysis.dt", f"must not exceed t_end - t_start = {self.t_end - self.t_start:g} s", self.dt)
        if self.integrator not in INTEGRATORS:
            raise SceneError(f"analysis.integrator: must be one of {sorted(set(INTEGRATORS.values()))} (aliases "
                             f"{sorted(INTEGRATORS)}), got {self.integrator!r}")
        self.integrator = INTEGRATORS[self.integrator]
        self.scheme()  # checks rho_inf / alpha / beta, gamma
        if self.dt_min is not None:
            if self.dt_min > self.dt:
                raise fail("analysis.dt_min", f"must not exceed dt = {self.dt:g}", self.dt_min)
        if self.dt_max is not None:
            if self.dt_max < self.dt:
                raise fail("analysis.dt_max", f"must not be below dt = {self.dt:g}", self.dt_max)
        given = [k for k in ("output_every", "output_dt", "output_times") if getattr(self, k) is not None]
        if len(given) > 1:
            raise fail("analysis", "give one of output_every, output_dt, output_times", given)
        if self.output_every is not None:
            if self.adaptive:
                raise fail("analysis.output_every", "needs fixed steps; with adaptive = true give output_dt or "
                           "output_times")
        if self.output_times is not None:
            if isinstance(self.output_times, (str, bytes)) or not isinstance(self.output_times,
                                                                             (list, tuple, np.ndarray)):
                raise fail("analysis.output_times", "must be a list of numbers", self.output_times)
            ot = np.array([number(f"analysis.output_times[{i}]", v)
                           for i, v in enumerate(np.asarray(self.output_times, dtype=object).ravel())])
            eps = 1e-12 * max(1.0, abs(self.t_end))
            bad = ot[~np.isfinite(ot) | (ot < self.t_start - eps) | (ot > self.t_end + eps)]
            if len(bad):
                raise fail("analysis.output_times", f"must lie in [t_start, t_end] = [{self.t_start:g}, "
                           f"{self.t_end:g}]", bad.tolist())
            self.output_times = np.unique(np.clip(ot, self.t_start, self.t_end))
        if isinstance(self.newton, dict):
            unknown = set(self.newton) - set(NewtonOptions.__dataclass_fields__)
            if unknown:
                raise SceneError(f"newton: unknown option(s) {sorted(unknown)}; known: "
                                 f"{sorted(NewtonOptions.__dataclass_fields__)}")
            self.newton = NewtonOptions(**self.newton)
        elif not isinstance(self.newton, NewtonOptions):
            raise SceneError(f"newton must be a table of Newton options, got {self.newton!r}")
        if not isinstance(self.sensors, (list, tuple)):
            raise SceneError(f"sensors must be a list, got {self.sensors!r}")
        self.sensors = [Sensor.from_dict(s, i) for i, s in enumerate(self.sensors)]
        names = [s.name for s in self.sensors]
        if len(set(names)) != len(names):
            raise SceneError(f"sensor names must be unique, got {names}")
        if not isinstance(self.loads, (list, tuple)):
            raise SceneError(f"loads must be a list, got {self.loads!r}")
        self.loads = [TimeLoad.from_dict(d, i) for i, d in enumerate(self.loads)]

    @property
    def n_grid(self) -> int:
        """Whole steps of dt in [t_start, t_end] (a shorter last step, if any, comes after them)."""
        return int(math.floor((self.t_end - self.t_start) / self.dt + 1e-9))

    def scheme(self) -> Scheme | None:
        if self.integrator == "newmark":
            return Scheme.newmark(_num("beta", self.beta), _num("gamma", self.gamma))
        if self.integrator == "hht":
            return Scheme.hht(_num("alpha", self.alpha))
        if self.integrator == "generalized_alpha":
            return Scheme.generalized_alpha(_num("rho_inf", self.rho_inf))
        return None


@dataclass
class DynamicResult:
    status: str  # "completed" | "newton_failed" | "step_size_underflow" | "energy_blowup"
    success: bool
    message: str
    integrator: str
    t: np.ndarray  # output times [s]
    sensors: dict  # name -> (len(t), k) array
    energies: dict  # name -> (len(t),) array [J]
    constraint_violation: np.ndarray  # max |Phi| over all supports and joints (exact and penalty) [m]
    t_reached: float
    steps: int  # accepted steps
    rejected: list  # one record per rejected step attempt
    counters: dict  # newton_iterations, residuals, jacobians, factorizations
    wall_s: float  # the time loop (initial acceleration, steps, outputs)
    x: np.ndarray  # final coordinates (full)
    v: np.ndarray  # final velocities (full)
    options: DynamicOptions | None = None
    assembly: Assembly | None = None
    h_min: float = float("nan")
    h_max: float = float("nan")
    setup_s: float = 0.0  # building the compiled step functions (before the time loop; not in wall_s)
    cpu_s: float = 0.0  # CPU time of the time loop (process time: what other processes on the machine take counts less)
    # per drive (ancf_sym.drives): what it applies at the output times, (len(t), k): an angle drive's torque on its
    # body [N m], a position drive's force [N] (from the multipliers; linear in time between steps)
    drive_reactions: dict = field(default_factory=dict)

    @property
    def newton_iterations(self) -> int:
        return int(self.counters.get("newton_iterations", 0))

    @property
    def factorizations(self) -> int:
        return int(self.counters.get("factorizations", 0))

    def energy_error(self) -> float | None:
        """max |algorithmic energy| over the run relative to the largest of |E(0)|, max kinetic, max |potential|
        (None when the energies were not recorded)."""
        alg = self.energies.get("algorithmic")
        if alg is None or not len(alg):
            return None
        scale = max(float(np.max(np.abs(self.energies["kinetic"]))), float(np.max(np.abs(self.energies["potential"]))),
                    abs(float(self.energies["total"][0])), 1e-300)
        return float(np.max(np.abs(alg)) / scale)

    def to_dict(self) -> dict:
        o = self.options
        return {
            "status": self.status, "success": self.success, "message": self.message, "integrator": self.integrator,
            "dt": o.dt if o else None, "t_end": o.t_end if o else None, "adaptive": o.adaptive if o else None,
            "t_reached": self.t_reached, "steps": self.steps, "rejected_steps": len(self.rejected),
            "rejected": self.rejected, **{k: int(v) for k, v in self.counters.items()}, "wall_s": self.wall_s,
            "setup_s": self.setup_s, "cpu_s": self.cpu_s,
            "h_min": self.h_min if self.steps else None, "h_max": self.h_max if self.steps else None,
            "energy_error": self.energy_error(),
            "t": self.t.tolist(),
            "sensors": {k: np.asarray(v).tolist() for k, v in self.sensors.items()},
            "energies": {k: np.asarray(v).tolist() for k, v in self.energies.items()},
            "constraint_violation": self.constraint_violation.tolist(),
            "x": self.x.tolist(), "v": self.v.tolist(),
            **({"drive_reactions": {k: np.asarray(v).tolist() for k, v in self.drive_reactions.items()}}
               if self.drive_reactions else {}),
        }


# -- the run -----------------------------------------------------------------------------------------------------

def rayleigh_data(asm: Assembly, terms: list) -> RayleighData | None:
    """Rayleigh damping requested by the scene (scene.dampings) with per-element weights of each term."""
    scene = asm.scene
    ds = [d for d in getattr(scene, "dampings", []) if d.kind == "rayleigh"]
    if not ds:
        return None
    alphas = {d.alpha for d in ds if d.alpha}
    if len(alphas) > 1 or any(d.members is not None for d in ds if d.alpha):
        raise SceneError("mass-proportional Rayleigh damping (alpha) must be one value for the whole scene, got "
                         f"{sorted(alphas)}")
    alpha = alphas.pop() if alphas else 0.0
    betas = {}
    for d in ds:
        if d.beta:
            for name in (d.members or list(scene.members)):
                betas[name] = d.beta
    beta_ref = max(betas.values()) if betas else 0.0
    weights = {}
    if beta_ref:
        starts = np.array([mm.offset for mm in asm.mesh.members.values()])
        factor = np.array([betas.get(name, 0.0) / beta_ref for name in asm.mesh.members])
        for ti, mk in enumerate(terms):
            member = np.searchsorted(starts, mk.term.idx[:, 0], side="right") - 1
            weights[ti] = factor[member]
    return RayleighData(float(alpha), float(beta_ref), weights)


def strain_rate_data(asm: Assembly) -> StrainRateData | None:
    """Gauss points (5 per element) of the members with strain-rate damping: r_x and r_xx as sparse maps."""
    ds = [d for d in getattr(asm.scene, "dampings", []) if d.kind == "strain_rate"]
    if not ds:
        return None
    coef: dict[str, list] = {}
    for d in ds:
        for name in (d.members or list(asm.scene.members)):
            c = coef.setdefault(name, [0.0, 0.0])
            c[0], c[1] = c[0] + d.axial, c[1] + d.bending
    dim = asm.scene.dim
    xg, wg = np.polynomial.legendre.leggauss(5)
    xi, wq = (xg + 1) / 2, wg / 2
    rows_x, rows_xx, wl, ca_, cb_, green = [], [], [], [], [], []
    for name, (c_ax, c_be) in coef.items():
        mm = asm.mesh.members[name]
        if mm.member.element == "beam3d":
            raise SceneError(f"strain_rate_damping: member {name!r} is a beam3d (cables only)")
        for e, (na, nb) in enumerate(mm.elem_nodes):
            L = mm.elem_length[e]
            da, db = mm.node_dofs(na), mm.node_dofs(nb)
            _, wx, wxx = weights(xi, L)  # (4, 5)
            for k in range(5):
                rows_x.append((da, db, list(wx[:, k])))
                rows_xx.append((da, db, list(wxx[:, k])))
                wl.append(wq[k] * L)
                ca_.append(c_ax)
                cb_.append(c_be)
                green.append(mm.member.axial == "green")
    P = len(wl)

    def matrix(rows):
        r, c, v = [], [], []
        for p, (da, db, w) in enumerate(rows):
            for comp in range(dim):
                for dofs, w_r, w_t in ((da, w[0], w[1]), (db, w[2], w[3])):
                    r += [comp * P + p, comp * P + p]
                    c += [dofs[comp], dofs[dim + comp]]
                    v += [w_r, w_t]
        return sp.csr_matrix((v, (r, c)), shape=(dim * P, asm.n))

    return StrainRateData(dim, matrix(rows_x), matrix(rows_xx), np.array(wl), np.array(ca_), np.array(cb_),
                          np.array(green))


def _collect_outputs(opts: DynamicOptions) -> np.ndarray | None:
    if opts.output_times is not None:
        return np.asarray(opts.output_times, float)
    if opts.output_dt is not None:
        n = int(math.floor((opts.t_end - opts.t_start) / opts.output_dt + 1e-9))
        ts = opts.t_start + opts.output_dt * np.arange(n + 1)
        if opts.t_end - ts[-1] > 1e-9 * opts.output_dt:
            ts = np.r_[ts, opts.t_end]
        return ts
    return None


def _hermite(t0, t1, q0, v0, q1, v1, tau):
    """q and q' at tau of the cubic through (q0, v0) at t0 and (q1, v1) at t1: interpolation.weights in time."""
    w, wx, _ = weights((tau - t0) / (t1 - t0), t1 - t0)
    return w[0] * q0 + w[1] * v0 + w[2] * q1 + w[3] * v1, wx[0] * q0 + wx[1] * v0 + wx[2] * q1 + wx[3] * v1


class _Recorder:
    def __init__(self, system: StepSystem, sensors: list[_SensorEval], energies: bool = True):
        self.S = system
        self.sensors = sensors
        self.with_energies = energies
        self.t: list[float] = []
        self.data: dict[str, list] = {s.sensor.name: [] for s in sensors}
        self.energies: dict[str, list] = {}
        self.viol: list[float] = []
        self.reactions: dict[str, list] = {}
        self.E0 = None
        self.scale = 0.0  # running energy scale: |T| + sum |potentials| + |works| + |E0|
        self.blowup: tuple | None = None  # (t, energy created, scale) once the scheme has created energy

    def energy(self, qf, vf):
        T, pot = self.S.energies(qf, vf)
        return T, pot, T + float(sum(pot.values()))

    def record(self, t, qf, vf, damping_work, external_work, lam=None):
        S = self.S
        x, v = S.full(qf), S.full_v(vf)
        if S.drives is not None and S.drives.m and lam is not None:
            for name, val in S.drives.reactions(x, lam[S.mc - S.drives.m:]).items():
                self.reactions.setdefault(name, []).append(val)
        for s in self.sensors:
            self.data[s.sensor.name].append(s(x, v))
        if self.with_energies:
            T, pot, E = self.energy(qf, vf)
            algorithmic = self.E0 + external_work - damping_work - E
            en = self.energies
            if not en:  # the columns, in this order, once (the labels of a scene's potentials do not change)
                for k in ("kinetic", "potential", *(f"potential_{k}" for k in pot), "total", "damping_work",
                          "external_work", "algorithmic"):
                    en[k] = []
            en["kinetic"].append(T)
            en["potential"].append(E - T)
            for k, val in pot.items():
                en["potential_" + k].append(val)
            en["total"].append(E)
            en["damping_work"].append(damping_work)
            en["external_work"].append(external_work)
            en["algorithmic"].append(algorithmic)
            self.scale = max(self.scale, abs(T) + sum(map(abs, pot.values())) + abs(damping_work)
                             + abs(external_work) + abs(self.E0))
            created = -algorithmic
            if self.blowup is None and created > ENERGY_CREATION_LIMIT * self.scale:
                self.blowup = (float(t), created, self.scale)
        self.viol.append(self._violation(x, t))
        self.t.append(float(t))

    def _violation(self, x: np.ndarray, t: float) -> float:
        """max |Phi(x)| over all supports and joints (the linear rows as a small dense matrix when it is small),
        and the drives' rows at time t."""
        cons = self.S.asm.constraints
        d = self.S.drives
        drive = float(np.abs(d.value(x, d.w(t))).max()) if d is not None and d.m else 0.0
        if not cons.m:
            return drive
        if not hasattr(self, "_cA"):
            self._cA = cons.A.toarray() if cons.m * cons.A.shape[1] <= 200_000 else cons.A
        val = self._cA @ x - cons.d
        if len(cons.qrow):
            val += np.bincount(cons.qrow, cons.qcoef * x[cons.qi] * x[cons.qj], minlength=cons.m)
        return max(float(np.abs(val).max()), drive)


# The alpha schemes dissipate (or, Newmark, conserve to O(h^2)); a run whose energy balance shows the scheme
# *creating* more than this fraction of the energy scale has gone unstable (Newton can still "converge" every step
# of a blow-up, e.g. a 10 N step load on paper 002's string at dt = 1e-4): it stops with status energy_blowup.
ENERGY_CREATION_LIMIT = 0.1
CHUNK = 64  # steps per compiled call in fixed-step runs of the alpha schemes (the rest of the grid: step by step)


def chunk_size(n_grid: int) -> int:
    """Steps per compiled call on a fixed grid of n_grid steps (0: none, shorter than CHUNK): the size in
    [CHUNK/2, CHUNK] that leaves the fewest steps to the one-by-one loop (a step there costs ~2x a chunked one),
    the largest of those; e.g. 1000 steps: 20 x 50 instead of 15 x 64 + 40."""
    if n_grid < CHUNK:
        return 0
    return min(range(CHUNK // 2, CHUNK + 1), key=lambda s: (n_grid % s, -s))
DEFAULT_OUTPUTS = 200  # output intervals when none of output_every, output_dt, output_times is given


class _Run:
    """The time loop: fixed or adaptive steps with rejection, or (fixed step, alpha scheme, full Newton) chunks of
    chunk_size(n) steps in one compiled call; bookkeeping and outputs per accepted step."""

    def __init__(self, S, integ, opts, loads, rec, outputs, every, progress, dt_min, dt_max, err_tol):
        self.S, self.integ, self.opts, self.loads, self.rec = S, integ, opts, loads, rec
        self.outputs, self.every, self.progress = outputs, every, progress
        self.dt_min, self.dt_max, self.err_tol = dt_min, dt_max, err_tol
        self.t = opts.t_start
        self.eps_t = 1e-9 * opts.dt
        self._const_pl: dict = {}
        self.W_d = self.W_ext = 0.0
        self.steps, self.rejected = 0, []
        self.status, self.message = "completed", ""
        self.h_min, self.h_max = math.inf, 0.0
        self.fd_prev = S.damping_force(integ.q, integ.v) if S.damped else None
        self.Qn = loads(opts.t_start) if loads else None
        self.fD_prev = S.drive_force(integ.q, integ.lam, self.t)  # drives' and torques' force (their work: external)
        self.lam_prev = integ.lam.copy()
        self.out_i = 0
        if outputs is None or outputs[0] <= self.t + self.eps_t:
            rec.record(self.t, integ.q, integ.v, 0.0, 0.0, integ.lam)
            self.out_i = 1

    # -- bookkeeping ------------------------------------------------------------------------------------------
    def _accepted(self, t_old, t_new, q_old, v_old, q_new, v_new, fd, lam_new=None):
        """Work of the scheme's own forces along the step, dq.(f_n + f_n+1)/2 (the trapezoidal rule's energy
        identity, exact for Newmark; f_n is the force of the equation that ended at t_n, with its damping matrix),
        then the outputs in (t_old, t_new]. lam_new: the multipliers at t_new (drives' reactions)."""
        lam_old = self.lam_prev
        if self.fD_prev is not None:
            fD = self.S.drive_force(q_new, lam_new, t_new)
            self.W_ext += 0.5 * float((q_new - q_old) @ (self.fD_prev + fD))
            self.fD_prev = fD
            self.lam_prev = np.array(lam_new, float)
        if fd is not None or self.loads is not None:
            dq = q_new - q_old
            if fd is not None:
                self.W_d += 0.5 * float(dq @ (self.fd_prev + fd))
                self.fd_prev = fd
            if self.loads is not None:
                Qnew = self.loads(t_new)
                self.W_ext += 0.5 * float(dq @ (self.Qn + Qnew))
                self.Qn = Qnew
        self.steps += 1
        h = t_new - t_old
        self.h_min, self.h_max = min(self.h_min, h), max(self.h_max, h)
        self.t = t_new
        rec, out = self.rec, self.outputs
        if out is None:
            if self.steps % self.every == 0 or t_new >= self.opts.t_end - self.eps_t:
                rec.record(t_new, q_new, v_new, self.W_d, self.W_ext, lam_new)
                if self.progress:
                    self.progress(t_new, self.opts.t_end)
            return
        while self.out_i < len(out) and out[self.out_i] <= t_new + self.eps_t:
            tau = out[self.out_i]
            if abs(tau - t_new) <= self.eps_t:
                rec.record(tau, q_new, v_new, self.W_d, self.W_ext, lam_new)
            else:
                qi, vi = _hermite(t_old, t_new, q_old, v_old, q_new, v_new, tau)
                li = None if lam_new is None else lam_old + (tau - t_old) / (t_new - t_old) * (lam_new - lam_old)
                rec.record(tau, qi, vi, self.W_d, self.W_ext, li)
            self.out_i += 1
            if self.progress:
                self.progress(tau, self.opts.t_end)

    def _check_energy(self) -> None:
        """End the run (status energy_blowup) once the recorded energy balance shows the scheme creating energy."""
        b = self.rec.blowup
        if b is not None and self.status == "completed":
            self.status = "energy_blowup"
            self.message = (f"the integrator created {b[1]:.3g} J by t = {b[0]:.6g} s, more than "
                            f"{ENERGY_CREATION_LIMIT:g} x the energy scale {b[2]:.3g} J: the run went unstable "
                            f"(try a smaller dt or more numerical dissipation); outputs after that time are not valid")

    # -- loops ------------------------------------------------------------------------------------------------
    def go(self):
        o = self.opts
        if o.adaptive:
            return self.per_step(o.t_end)
        n_grid = o.n_grid
        k = 0
        if isinstance(self.integ, AlphaIntegrator) and self.integ.chunkable:
            size = chunk_size(n_grid)
            while size and n_grid - k >= size and self.status == "completed":
                n_ok = self.chunk(k, size)
                k += n_ok
                if n_ok < size:  # the graph flagged step k+1: the per-step loop takes it (Newton in Python, rejection)
                    self.per_step(self.grid(k + 1), k)
                    k += 1
            if k < n_grid and self.status == "completed":  # the rest (< size steps): the same step graph, one by one
                self.per_step(self.grid(n_grid), k)  # (cheaper than building a chunk function of that length)
        else:
            self.per_step(o.t_start + n_grid * o.dt, 0)
        if self.status == "completed" and self.t < o.t_end - self.eps_t:
            self.per_step(o.t_end, n_grid)

    def grid(self, k: int) -> float:
        return self.opts.t_start + k * self.opts.dt

    def chunk(self, k: int, n: int) -> int:
        """Steps k+1 .. k+n in one call; returns how many were accepted."""
        integ, S, o = self.integ, self.S, self.opts
        nf = S.nf
        if self.loads is None:  # the same constant load at every step: one array per chunk length
            pl = self._const_pl.get(n)
            if pl is None:
                pl = self._const_pl[n] = np.repeat(-S.f_lin[:, None], n, axis=1)
                pl.flags.writeable = False  # (run_chunk copies a read-only load array into its buffer once)
        else:
            pl = -np.column_stack([S.f_lin + self.loads(self.grid(k + j + 1)) for j in range(n)])
        if S.nw:  # the drives' time inputs below the loads
            pl = np.vstack([pl, np.column_stack([S.w(self.grid(k + j + 1)) for j in range(n)])])
        q_old, v_old = integ.q.copy(), integ.v.copy()
        states, n_ok = integ.run_chunk(o.dt, pl)
        t_old = self.t
        if not S.damped and self.loads is None and S.drives is None:  # no work to book per step: only the outputs
            self._accepted_many(k, n_ok, states, q_old, v_old)
            self._check_energy()
            return n_ok
        for j in range(n_ok):
            t_new = self.grid(k + j + 1)
            q_new, v_new = states[j, :nf], states[j, nf:2 * nf]
            fd = S.damping_force(q_new, v_new) if S.damped else None
            self._accepted(t_old, t_new, q_old, v_old, q_new, v_new, fd, states[j, 5 * nf:5 * nf + S.mc])
            t_old, q_old, v_old = t_new, q_new, v_new
        self._check_energy()
        return n_ok

    def _accepted_many(self, k: int, n_ok: int, states: np.ndarray, q_old: np.ndarray, v_old: np.ndarray):
        """Bookkeeping of the accepted grid steps k+1 .. k+n_ok of a chunk (nothing to integrate along them): the
        outputs that fall in them, as `_accepted` would record them step by step."""
        if not n_ok:
            return
        nf = self.S.nf
        rec, out, o = self.rec, self.outputs, self.opts
        t_first = self.t
        steps0 = self.steps
        self.steps += n_ok
        self.h_min, self.h_max = min(self.h_min, o.dt), max(self.h_max, o.dt)
        self.t = self.grid(k + n_ok)
        if out is None:
            last = self.steps if self.t >= o.t_end - self.eps_t else None
            for s in range(steps0 + 1, self.steps + 1):
                if s % self.every == 0 or s == last:
                    j = s - steps0 - 1
                    rec.record(self.grid(k + j + 1), states[j, :nf], states[j, nf:2 * nf], self.W_d, self.W_ext)
                    if self.progress:
                        self.progress(self.grid(k + j + 1), o.t_end)
            return
        T = o.t_start + (k + 1 + np.arange(n_ok)) * o.dt  # = self.grid(k + j + 1), without a Python loop
        while self.out_i < len(out) and out[self.out_i] <= T[-1] + self.eps_t:
            tau = out[self.out_i]
            j = int(np.searchsorted(T, tau - self.eps_t))
            q1, v1 = states[j, :nf], states[j, nf:2 * nf]
            if abs(tau - T[j]) <= self.eps_t:
                rec.record(tau, q1, v1, self.W_d, self.W_ext)
            else:
                if j == 0:
                    t0, q0, v0 = t_first, q_old, v_old
                else:
                    t0, q0, v0 = T[j - 1], states[j - 1, :nf], states[j - 1, nf:2 * nf]
                qi, vi = _hermite(t0, T[j], q0, v0, q1, v1, tau)
                rec.record(tau, qi, vi, self.W_d, self.W_ext)
            self.out_i += 1
            if self.progress:
                self.progress(tau, o.t_end)

    def per_step(self, t_stop: float, k_grid: int = 0):
        """Single steps with rejection (halving on Newton failure, error control if adaptive) until t_stop."""
        o, integ = self.opts, self.integ
        eps_t = self.eps_t
        h = o.dt
        while self.t < t_stop - eps_t and self.status == "completed":
            t = self.t
            if o.adaptive:
                h_try = min(h, self.dt_max, o.t_end - t)
            else:
                h_try = min(h, t_stop - t)
            if t_stop - (t + h_try) < eps_t:
                h_try = t_stop - t
            t_new = t + h_try
            if abs(t_new - t_stop) <= eps_t:
                t_new = t_stop  # no round-off drift of the fixed-step grid
                h_try = t_new - t
            out = integ.attempt(t, h_try, self.loads)
            reject_reason, err_ratio = None, None
            if not out.converged:
                reject_reason = f"newton: {out.reason}"
            elif o.adaptive:
                e = integ.error_estimate(h_try)
                err_ratio = float(np.max(np.abs(e))) / self.err_tol if len(e) else 0.0
                if not math.isfinite(err_ratio) or err_ratio > 1.0:
                    reject_reason = f"error estimate {err_ratio:.3g} x tol"
            if reject_reason is not None:
                self.rejected.append({"t": t, "h": h_try, "reason": reject_reason, "iterations": out.iterations})
                factor = 0.5 if err_ratio is None or not math.isfinite(err_ratio) else \
                    max(0.2, min(0.9, 0.9 * err_ratio ** (-1.0 / (integ.order + 1))))
                h = h_try * factor
                if h < self.dt_min:
                    self.status = "newton_failed" if err_ratio is None else "step_size_underflow"
                    self.message = (f"step at t = {t:.6g} s rejected with h = {h_try:.3g} s ({reject_reason}); a "
                                    f"smaller step would go below dt_min = {self.dt_min:.3g} s")
                    return
                continue
            q_old, v_old = integ.q.copy(), integ.v.copy()
            q_new, v_new = integ.new["q"].copy(), integ.new["v"].copy()
            fd = self.S.damping_force(q_new, v_new) if self.S.damped else None  # (K_el of this step)
            integ.accept()
            self._accepted(t, t_new, q_old, v_old, q_new, v_new, fd, integ.lam)
            self._check_energy()
            if o.adaptive:  # grow only with a clear margin (the estimate is noisy on stiff, slender members)
                f = 0.8 * max(err_ratio, 1e-10) ** (-1.0 / (integ.order + 1))
                h = min(h_try * min(1.25, max(1.0, f)), self.dt_max) if err_ratio < 0.5 else h_try
            elif h < o.dt:
                h = min(o.dt, 2 * h)  # after a rejection, climb back towards dt


def make_integrator(system: StepSystem, opts: DynamicOptions, counters: Counters, tol_q: float, tol_x: float):
    if opts.integrator in ("radau", "gauss"):
        from .collocation import CollocationIntegrator
        stages = opts.stages or (3 if opts.integrator == "radau" else 2)
        return CollocationIntegrator(system, opts.integrator, stages, opts.newton, tol_q, tol_x, counters)
    return AlphaIntegrator(system, opts.scheme(), opts.newton, tol_q, tol_x, counters)


def simulate(scene: Scene | Assembly, options: DynamicOptions, progress: Callable[[float, float], Any] | None = None,
             system: StepSystem | None = None) -> DynamicResult:
    """Integrate a scene from options.t_start to options.t_end (see the module docstring)."""
    opts = options
    asm = scene if isinstance(scene, Assembly) else Assembly(scene)
    scene = asm.scene
    if not scene.members and not scene.bodies:
        raise SceneError("scene has no members or bodies")
    contact.check_dynamics(asm)
    if getattr(scene, "drives", None) and opts.integrator in ("radau", "gauss"):
        raise SceneError(f"integrator={opts.integrator!r}: drives and torques (time-dependent constraints and "
                         "forces) run with the alpha schemes (newmark, hht, generalized_alpha), not collocation")
    sensors = [_SensorEval(s, asm, i) for i, s in enumerate(opts.sensors)]
    if system is None:
        system = StepSystem(asm, rayleigh_data(asm, [mk for mk in asm.mapped if mk.term.effect not in LINEAR_EFFECTS]),
                            strain_rate=strain_rate_data(asm))
    S = system
    loads = _LoadSum(opts.loads, asm, S.E) if opts.loads else None
    # initial state
    q0 = asm.x0.copy() if opts.q0 is None else np.asarray(opts.q0, dtype=float).ravel()
    if opts.start == "static":
        q0 = initial_state.static_start(scene)
    v0 = np.zeros(asm.n) if opts.v0 is None else np.asarray(opts.v0, dtype=float).ravel()
    if opts.initial:
        v0 = initial_state.from_specs(asm, q0, opts.initial)
    for name, arr in (("q0", q0), ("v0", v0)):
        if arr.shape != (asm.n,):
            raise SceneError(f"{name} must have {asm.n} entries (the scene's coordinates), got {arr.size}")
        if not np.all(np.isfinite(arr)):
            raise SceneError(f"{name} must be finite")
    if opts.q0 is not None:
        check_stretch(asm.mesh, q0, "q0")
    L = S.length_scale
    tol_x = opts.newton.xtol * L
    cons_tol = max(1e-8 * L, 10 * tol_x)
    if asm.exact.m:
        viol = np.abs(asm.exact.value(q0))
        if viol.max() > cons_tol:
            k = int(np.argmax(viol))
            raise SceneError(f"q0 violates constraint {asm.exact.labels[k]!r} by {viol[k]:.3g} m (tolerance "
                             f"{cons_tol:.3g} m)")
        vv = np.abs(asm.exact.jacobian(q0) @ v0)
        if vv.max() > 1e-8 * max(1.0, float(np.abs(v0).max())):
            k = int(np.argmax(vv))
            raise SceneError(f"v0 violates the velocity form of constraint {asm.exact.labels[k]!r} by {vv[k]:.3g}")
    drv = S.drives
    if drv is not None and drv.m:  # the drives at t_start: position and velocity
        w0 = drv.w(opts.t_start)
        viol = np.abs(drv.value(q0, w0))
        vv = np.abs(drv.jacobian(q0, w0) @ v0 + drv.time_terms(q0, v0, opts.t_start)[0])
        for what, arr, tol in (("q0", viol, cons_tol), ("v0 (velocity form)", vv, 1e-8 * max(1.0, float(np.abs(v0).max())))):
            if arr.max() > tol:
                k = int(np.argmax(arr))
                raise SceneError(f"{what} violates drive {drv.labels[k]!r} at t_start = {opts.t_start:g} s by "
                                 f"{arr[k]:.3g} (start the body or node where and as fast as the drive prescribes, "
                                 "e.g. a motion that starts from rest)")
    outputs = _collect_outputs(opts)
    every = opts.output_every
    if every is None and outputs is None:  # default: about DEFAULT_OUTPUTS intervals
        if opts.adaptive:
            n_out = DEFAULT_OUTPUTS
            outputs = opts.t_start + (opts.t_end - opts.t_start) * np.arange(n_out + 1) / n_out
        else:
            every = max(1, int(round((opts.t_end - opts.t_start) / opts.dt / DEFAULT_OUTPUTS)))
    dt_min = opts.dt_min or opts.dt * 2.0 ** -12
    dt_max = opts.dt_max or (opts.dt * 100 if opts.adaptive else opts.dt)
    err_tol = opts.tol or 1e-6 * L

    t_setup = time.perf_counter()
    counters = Counters()
    integ = make_integrator(S, opts, counters, 0.0, tol_x)
    if isinstance(integ, AlphaIntegrator) and integ.chunkable and not opts.adaptive:
        n_grid = opts.n_grid
        if chunk_size(n_grid):
            integ.chunk_function(chunk_size(n_grid))  # compiled-call set-up, like the step graph itself
    setup = time.perf_counter() - t_setup
    t_wall, t_cpu = time.perf_counter(), time.process_time()
    qf, vf = S.reduce(q0), S.reduce(v0)
    Q0 = loads(opts.t_start) if loads else np.zeros(S.nf)
    integ.initialize(qf, vf, Q0, opts.t_start)
    # force scale of the residual tolerance: constant loads (gravity, dead loads), inertia at t0, time loads
    fscale = max(float(np.max(np.abs(S.f_lin))), float(np.max(np.abs(S.M @ integ.a))),
                 float(np.max(np.abs(Q0)))) if S.nf else 0.0
    integ.tol_q = opts.newton.tol * max(fscale, 1e-300)

    rec = _Recorder(S, sensors, opts.energies)
    rec.E0 = rec.energy(integ.q, integ.v)[2] if opts.energies else None
    run = _Run(S, integ, opts, loads, rec, outputs, every, progress, dt_min, dt_max, err_tol)
    run.go()
    wall, cpu = time.perf_counter() - t_wall, time.process_time() - t_cpu
    t, status, message, steps, rejected = run.t, run.status, run.message, run.steps, run.rejected
    h_used = [run.h_min, run.h_max] if steps else []
    sens = {name: np.array(vals) for name, vals in rec.data.items()}
    ener = {k: np.array(v) for k, v in rec.energies.items()}
    return DynamicResult(status, status == "completed", message, opts.integrator, np.array(rec.t), sens, ener,
                         np.array(rec.viol), float(t), steps, rejected, counters.as_dict(), wall,
                         S.full(integ.q), S.full_v(integ.v), opts, asm,
                         float(min(h_used)) if h_used else float("nan"), float(max(h_used)) if h_used else float("nan"),
                         setup, cpu, {k: np.array(v) for k, v in rec.reactions.items()})


ANALYSIS_KEYS = {"type", *DYNAMIC_OPTIONS}


def options_from_dict(analysis: dict) -> DynamicOptions:
    """DynamicOptions from a TOML [analysis] table of type "dynamics" (keys as the DynamicOptions fields)."""
    if not isinstance(analysis, dict):
        raise SceneError(f"analysis must be a table, got {analysis!r}")
    if analysis.get("type", "dynamics") != "dynamics":
        raise SceneError(f"analysis.type must be 'dynamics' here, got {analysis.get('type')!r}")
    check_keys("analysis", analysis, ("type", *DYNAMIC_OPTIONS), ("dt", "t_end"))
    kw = {k: v for k, v in analysis.items() if k != "type"}
    try:
        return DynamicOptions(**kw)
    except SceneError as exc:  # sub-tables (newton, sensors, loads) name their field from inside the table
        msg = str(exc)
        if msg.startswith("analysis"):
            raise
        head = re.match(r"(newton|sensors|loads|initial)\b[.\[:]?", msg)
        raise SceneError(f"analysis.{msg}" if head else f"analysis: {msg}") from None


def run_dynamics(scene: Scene | Assembly, analysis: dict | DynamicOptions,
                 progress: Callable[[float, float], Any] | None = None) -> DynamicResult:
    """Run a dynamic analysis: `analysis` is the [analysis] table (type "dynamics") or DynamicOptions.

    progress(t, t_end) is called at every output time. Bad input raises SceneError before any step."""
    opts = analysis if isinstance(analysis, DynamicOptions) else options_from_dict(analysis)
    return simulate(scene, opts, progress)
