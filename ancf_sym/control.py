"""Optimal control of cable scenes by direct collocation, solved with IPOPT (exact sparse Hessian).

    from ancf_sym.control import ControlProblem, SupportMotion, PointMass, Effort
    ocp = ControlProblem(scene, controls=[SupportMotion("cable", "start", axes=(0,), name="trolley")],
                         horizon=4.0, point_masses=[PointMass("cable", "end", 100.0)], cost=[Effort()],
                         end={"trolley.position": 2.0}, bounds={"trolley.acceleration": (-2, 2)},
                         intervals=20, stages=3, scheme="radau")
    res = ocp.solve()                 # warm start: the collocation simulation of a quintic rest-to-rest motion
    res.status, res.cost, res.iterations, res.wall_s
    check = res.resimulate()          # the dynamics integrator on the optimal controls
    check.mismatch_m, check.residual_swing_m

Dynamics. The scene's free coordinates q (supports and hinges eliminated as in the dynamics module) obey

    M_ff q'' + M_fc s'' + grad_f U(E q + c + B s) - f_lin - B_f F = 0

where s are the displacements of controlled supports (states s, s'; control s'' = acceleration), F the magnitudes
of controlled point forces, M the mass matrix with the point masses added and f_lin the constant forces (gravity of
the cables and of the point masses, dead loads). Only grad U is nonlinear.

Transcription. K intervals of length h = T/K, each an implicit Runge-Kutta step of Radau IIA or Gauss-Legendre
with s stages (ancf_sym.collocation.tableau; equivalent to collocation with the polynomial through tau = 0 and the
points c_j). Variables per interval: the start velocity v_k, the stage positions Q_kj (Radau: the last stage is the
next interval's start position), the support states at the start and the stages, the controls at the stages (or
one per interval, control_form="constant"). With W = A^-1 the stage velocities and accelerations are linear,
V = W (Q - q_k) / h, a = W (V - v_k) / h, and per stage the dynamics residual above is a constraint; continuity of
v (and, for Gauss, of q) by the quadrature weights b. This condensed form has about half the variables of the
state-per-node form, and its KKT matrix factorises ~4x faster (measured fill 1.8M vs 6.8M at n = 8, K = 40).

Warm start: the same collocation equations integrated interval by interval (Newton on their exact sparse Jacobian)
for a quintic rest-to-rest support motion, so IPOPT starts with every dynamics row satisfied.

Derivatives. grad U at all collocation points is one mapped call per energy term. IPOPT gets its Jacobian from the
kernel Hessians and the Lagrangian Hessian from the kernels' third-derivative companions (load_hvp: d(H v)/dq with
v = the multipliers of the dynamics rows mapped to element coordinates), both assembled through constant sparse
matrices; everything else (collocation, continuity, costs, path constraints: linear or polynomial) is
differentiated by CasADi. No finite differences.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import casadi as ca
import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from . import kernels, registry
from .assembly import Assembly
from .collocation import tableau
from .checks import number
from .elements import hermite
from .integrators import LINEAR_EFFECTS, partition
from .scene import Scene, SceneError
from .sparsity import casadi_sparsity, csc_pattern

SUCCESS = ("Solve_Succeeded", "Solved_To_Acceptable_Level")
FULL_STEP_ITERATIONS = 150  # cap of the full-step attempt before IPOPT's line search takes over
SCHEMES = ("radau", "gauss")


# -- problem ingredients ----------------------------------------------------------------------------------------

_num = number  # (name, value, positive=False, nonneg=False)


@dataclass(frozen=True)
class PointMass:
    """A concentrated mass [kg] at a node of a member (e.g. a crane's payload); its weight follows scene.gravity."""
    member: str
    at: Any
    mass: float


@dataclass(frozen=True)
class SupportMotion:
    """Prescribed translation of a supported node (pin or clamp) along `axes` (0 = x, 1 = y, 2 = z).

    Each axis is a channel named `name` (one axis) or `name_x`, `name_y`, ... with the states
    `<channel>.position` (displacement from the reference [m]) and `<channel>.velocity` [m/s], and the control
    `<channel>.acceleration` [m/s^2]."""
    member: str
    at: Any = "start"
    axes: tuple = (0,)
    name: str = "support"


@dataclass(frozen=True)
class PointForce:
    """A controlled dead force of magnitude `<name>.force` [N] along the fixed `direction` at a node or material
    coordinate s [m] (float)."""
    member: str
    at: Any
    direction: Sequence[float]
    name: str = "force"


@dataclass(frozen=True)
class Effort:
    """Integral of sum_c w_c u_c^2 over the horizon; `weights` per control name (default 1 for all)."""
    weight: float = 1.0
    weights: dict | None = None


@dataclass(frozen=True)
class MinimumTime:
    """weight * T: the horizon becomes a decision variable (give `horizon` as (lower, guess, upper))."""
    weight: float = 1.0


@dataclass(frozen=True)
class Swing:
    """Integral of the kinetic energy of the scene relative to the controlled supports' translation [J s]."""
    weight: float = 1.0


@dataclass(frozen=True)
class PathConstraint:
    """lower <= fn(view) <= upper at every collocation point. fn receives a `StateView` of CasADi expressions
    (positions, velocities, support channels, controls) and returns an expression (scalar or vector); polynomial
    expressions keep IPOPT's exact Hessian cheap (CasADi differentiates them)."""
    fn: Callable
    lower: Any = -np.inf
    upper: Any = np.inf
    name: str = "path"


class StateView:
    """The state at one instant as CasADi expressions, for path constraints: x, v (full coordinates and velocities),
    point(member, at) / velocity(member, at) of a centreline point, and the support channels and controls by name."""

    def __init__(self, prob: "ControlProblem", x, v, chan_pos, chan_vel, u):
        self._p, self.x, self.v = prob, x, v
        self._cp, self._cv, self._u = chan_pos, chan_vel, u

    def point(self, member: str, at: Any = "end"):
        idx, w = self._p._probe(member, at)
        return ca.vertcat(*[ca.dot(ca.DM(w), self.x[row.tolist()]) for row in idx])

    def velocity(self, member: str, at: Any = "end"):
        idx, w = self._p._probe(member, at)
        return ca.vertcat(*[ca.dot(ca.DM(w), self.v[row.tolist()]) for row in idx])

    def __getitem__(self, key: str):
        name, _, what = key.rpartition(".")
        p = self._p
        if name in p.channels and what in ("position", "velocity", "acceleration"):
            k = p.channels.index(name)
            return {"position": self._cp, "velocity": self._cv, "acceleration": self._u}[what][
                k if what != "acceleration" else p._acc_index[k]]
        if name in p.force_names and what == "force":
            return self._u[p._force_index[p.force_names.index(name)]]
        raise SceneError(f"unknown state or control {key!r}; known: {p.variable_names()}")


# -- the assembly with point masses -----------------------------------------------------------------------------

class ControlAssembly(Assembly):
    """A scene's Assembly with point masses: their mass on the node's position coordinates, their weight (under
    scene.gravity) among the dead loads Q. Also what the dynamics integrator runs for the re-simulation."""

    def __init__(self, scene: Scene, point_masses: Sequence[PointMass] = ()):
        super().__init__(scene)
        self.point_masses = list(point_masses)
        self._pm_dofs = []
        dim = scene.dim
        for i, pm in enumerate(self.point_masses):
            if not isinstance(pm, PointMass):
                raise SceneError(f"point_masses[{i}] must be a PointMass, got {pm!r}")
            scene._check_at(pm.member, pm.at, node_only=True, field_name=f"point_masses[{i}].at")
            m = _num(f"point_masses[{i}].mass", pm.mass, positive=True)
            mm = self.mesh.members[pm.member]
            dofs = mm.node_dofs(mm.node(pm.at))[:dim]
            self._pm_dofs.append((dofs, m))
            self.Q[dofs] += m * np.asarray(scene.gravity, float)

    def mass_matrix(self) -> sp.csc_matrix:
        M = super().mass_matrix().tolil()
        for dofs, m in self._pm_dofs:
            for d in dofs:
                M[d, d] += m
        return M.tocsc()


# -- helpers ----------------------------------------------------------------------------------------------------

def _dm(A) -> ca.DM:
    A = sp.csc_matrix(A)
    A.sum_duplicates()
    A.sort_indices()
    return ca.DM(ca.Sparsity(A.shape[0], A.shape[1], A.indptr.tolist(), A.indices.tolist()), A.data.tolist())


def _scatter(n_rows: int, n_cols: int, rows: np.ndarray, cols: np.ndarray, n_entries: int, keep: np.ndarray,
             values: ca.MX) -> ca.MX:
    """Sparse MX (n_rows x n_cols) summing values[keep[i]] at (rows[i], cols[i])."""
    indptr, indices, inv = csc_pattern(rows, cols, n_rows, n_cols)
    spy = casadi_sparsity(n_rows, n_cols, indptr, indices)
    A = sp.coo_matrix((np.ones(len(inv)), (inv, keep)), shape=(len(indices), n_entries))
    return ca.MX(spy, ca.mtimes(_dm(A), values))


def _basis(nodes: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """Lagrange basis values l_r(tau) (len(tau) x len(nodes))."""
    out = np.ones((len(tau), len(nodes)))
    for r in range(len(nodes)):
        for m in range(len(nodes)):
            if m != r:
                out[:, r] *= (tau - nodes[m]) / (nodes[r] - nodes[m])
    return out


# -- the problem ------------------------------------------------------------------------------------------------

class ControlProblem:
    """Direct collocation of a scene's dynamics with IPOPT. See the module docstring.

    controls: SupportMotion and PointForce items. horizon: T [s] (fixed) or (lower, guess, upper) with a
    MinimumTime cost. cost: list of Effort, MinimumTime, Swing. bounds: {"<channel>.position"|".velocity"|
    ".acceleration"|"<force>.force": (lower, upper)}. start / end: values of support channels
    ({"trolley.position": 2.0}); both start and end at rest (zero support velocity, the scene at static equilibrium
    with zero velocity: at the end on its `end_modes` lowest vibration modes, default all below `end_frequency`
    [Hz], default K / (4 T): the modes the grid resolves; end_rest=False drops these rows). path: PathConstraint
    items, at every collocation point; terminal: PathConstraint items at T. point_masses: PointMass items.
    control_form: "polynomial" (a control value per collocation point: the Lagrange polynomial in each interval) or
    "constant" (one value per interval: bounds then hold at every instant, suited to bang-bang optima).
    """

    def __init__(self, scene: Scene, controls: Sequence, horizon: Any, point_masses: Sequence[PointMass] = (),
                 cost: Sequence = (Effort(),), bounds: dict | None = None, start: dict | None = None,
                 end: dict | None = None, path: Sequence[PathConstraint] = (),
                 terminal: Sequence[PathConstraint] = (), intervals: int = 20,
                 stages: int = 3, scheme: str = "radau", end_rest: bool = True, end_modes: int | None = None,
                 end_frequency: float | None = None, control_form: str = "polynomial", tol: float = 1e-8,
                 max_iter: int = 1000, print_level: int = 0, ipopt: dict | None = None):
        t0 = time.perf_counter()
        if not isinstance(scene, Scene):
            raise SceneError(f"scene must be a Scene, got {scene!r}")
        if not scene.members:
            raise SceneError("scene has no members")
        self.scene = scene
        # -- discretisation ---------------------------------------------------------------------------------
        if isinstance(intervals, bool) or not isinstance(intervals, (int, np.integer)) or intervals < 1:
            raise SceneError(f"intervals must be a positive integer, got {intervals!r}")
        if scheme not in SCHEMES:
            raise SceneError(f"scheme must be one of {SCHEMES}, got {scheme!r}")
        self.K, self.scheme = int(intervals), scheme
        if control_form not in ("polynomial", "constant"):
            raise SceneError(f"control_form must be 'polynomial' (a value per collocation point) or 'constant' (one "
                             f"per interval), got {control_form!r}")
        self.control_form = control_form
        self.tab = tableau(scheme, stages)
        self.s = self.tab.s
        if isinstance(max_iter, bool) or not isinstance(max_iter, (int, np.integer)) or max_iter < 1:
            raise SceneError(f"max_iter must be a positive integer, got {max_iter!r}")
        self.tol, self.max_iter, self.print_level = _num("tol", tol, positive=True), int(max_iter), int(print_level)
        self.ipopt_extra = dict(ipopt or {})
        # -- costs and horizon -----------------------------------------------------------------------------
        cost = list(cost) if isinstance(cost, (list, tuple)) else [cost]
        if not cost:
            raise SceneError("cost must name at least one term (Effort, MinimumTime, Swing)")
        for i, c in enumerate(cost):
            if not isinstance(c, (Effort, MinimumTime, Swing)):
                raise SceneError(f"cost[{i}] must be Effort, MinimumTime or Swing, got {c!r}")
            _num(f"cost[{i}].weight", c.weight, nonneg=True)
        self.cost = cost
        self.free_time = any(isinstance(c, MinimumTime) for c in cost)
        if self.free_time:
            if not isinstance(horizon, (tuple, list)) or len(horizon) != 3:
                raise SceneError(f"a MinimumTime cost needs horizon=(lower, guess, upper) [s], got {horizon!r}")
            lo, g, hi = (_num(f"horizon[{i}]", v) for i, v in enumerate(horizon))
            if not 0 < lo <= g <= hi:
                raise SceneError(f"horizon (lower, guess, upper) must satisfy 0 < lower <= guess <= upper, got "
                                 f"{tuple(horizon)!r}")
            self.T_bounds, self.T_guess = (lo, hi), g
        else:
            if isinstance(horizon, (tuple, list)):
                raise SceneError(f"horizon must be one number T [s] without a MinimumTime cost, got {horizon!r}")
            T = _num("horizon", horizon)
            if T <= 0:
                raise SceneError(f"horizon must be positive, got {horizon!r}")
            self.T_bounds, self.T_guess = (T, T), T
        # -- the scene, supports and controls ---------------------------------------------------------------
        self._check_scene()
        self.asm = ControlAssembly(scene, point_masses)
        self._setup_coordinates(controls)
        # -- bounds, start, end ------------------------------------------------------------------------------
        self.bounds = self._check_bounds(bounds or {})
        self.start_values = self._check_targets(start or {}, "start")
        self.end_values = self._check_targets(end or {}, "end")
        self._check_feasible()
        self.path, self.terminal = list(path), list(terminal)
        for label, items in (("path", self.path), ("terminal", self.terminal)):
            for i, pc in enumerate(items):
                if not isinstance(pc, PathConstraint) or not callable(pc.fn):
                    raise SceneError(f"{label}[{i}] must be a PathConstraint with a callable fn, got {pc!r}")
        self.end_rest = bool(end_rest)
        self.end_modes, self.end_frequency = end_modes, end_frequency
        if end_modes is not None and (isinstance(end_modes, bool) or not isinstance(end_modes, (int, np.integer))
                                      or end_modes < 1):
            raise SceneError(f"end_modes must be a positive integer, got {end_modes!r}")
        if end_frequency is not None:
            _num("end_frequency", end_frequency, positive=True)
        # -- equilibria and modes ------------------------------------------------------------------------------
        self._build_point_functions()
        self.q_start = self.equilibrium(self._chan_vector(self.start_values))
        self.q_end = self.equilibrium(self._chan_vector(self.end_values), guess=self._translated(
            self.q_start, self._chan_vector(self.end_values) - self._chan_vector(self.start_values)))
        self.modes = self._modes(self.q_end, self._chan_vector(self.end_values))
        # -- the NLP ---------------------------------------------------------------------------------------------
        self._build_nlp()
        self._solvers, self.solver_build_s = {}, 0.0
        self.build_s = time.perf_counter() - t0

    # -- checks ---------------------------------------------------------------------------------------------
    def _check_scene(self) -> None:
        sc = self.scene
        for m in sc.members.values():
            if not m.element.startswith("cable"):
                raise SceneError(f"member {m.name!r}: optimal control is available for cable elements (cable2d, "
                                 f"cable3d), got {m.element!r}")
            if len(m.points) > 2:
                raise SceneError(f"member {m.name!r}: polyline members (internal rigid joints) are not supported by "
                                 "the control module; use straight members")
        for ld in sc.loads:
            if ld.kind == "moment":
                raise SceneError("moment loads are not supported by the control module (their kernels have no "
                                 "third-derivative companion)")
        if getattr(sc, "dampings", None):
            kinds = sorted({d.kind for d in sc.dampings})
            raise SceneError(f"damping ({', '.join(kinds)}) is not supported by the control module yet")
        for j in sc.joints:
            if j.kind == "rigid":
                raise SceneError(f"rigid joints are not supported by the control module (multipliers), got {j}")

    def _setup_coordinates(self, controls) -> None:
        a, sc = self.asm, self.scene
        dim = sc.dim
        if a.penalty is not None:
            raise SceneError("penalty supports/joints are not supported by the control module; use method='exact'")
        self.part = part = partition(a)
        if len(part.rows):
            raise SceneError("the control module needs every support and joint eliminated (pins, clamps of "
                             "axis-aligned members, hinges); constraints with multipliers remain: "
                             f"{[a.exact.labels[r] for r in part.rows]}")
        self.n, self.nf = a.n, part.ny
        self.pos = part.pos
        self.E = part.E
        if not isinstance(controls, (list, tuple)) or not controls:
            raise SceneError("controls must be a non-empty list of SupportMotion / PointForce")
        self.channels, self._chan_coord, self._chan_axis, self._chan_support = [], [], [], []
        self.force_names, self._force_vecs = [], []
        names = set()
        for i, c in enumerate(controls):
            if isinstance(c, SupportMotion):
                if c.member not in sc.members:
                    raise SceneError(f"controls[{i}]: member {c.member!r} does not exist; members: "
                                     f"{sorted(sc.members)}")
                sc._check_at(c.member, c.at, node_only=True, field_name=f"controls[{i}].at")
                mm = a.mesh.members[c.member]
                node = mm.node(c.at)
                sup = [s for s in sc.supports if s.member == c.member and s.kind in ("pin", "clamp")
                       and mm.node(s.at) == node]
                if not sup:
                    raise SceneError(f"controls[{i}] ({c.name!r}) moves a support at {c.member}@{c.at!r}, but there "
                                     f"is no pin or clamp there; supports: "
                                     f"{[(s.kind, s.member, s.at) for s in sc.supports] or 'none'}")
                if any(s.method != "exact" for s in sup):
                    raise SceneError(f"controls[{i}]: the support at {c.member}@{c.at!r} must be exact, not penalty")
                for j in sc.joints:
                    for end in (j.a, j.b):
                        if end[0] == c.member and mm.node(end[1]) == node:
                            raise SceneError(f"controls[{i}]: the moved node {c.member}@{c.at!r} is also a joint")
                axes = tuple(c.axes) if isinstance(c.axes, (tuple, list)) else (c.axes,)
                if not axes or any(isinstance(ax, bool) or ax not in range(dim) for ax in axes) or \
                        len(set(axes)) != len(axes):
                    raise SceneError(f"controls[{i}].axes must be distinct axes in 0..{dim - 1}, got {c.axes!r}")
                dofs = mm.node_dofs(node)
                for ax in axes:
                    ch = c.name if len(axes) == 1 else f"{c.name}_{'xyz'[ax]}"
                    if ch in names:
                        raise SceneError(f"controls[{i}]: name {ch!r} used twice")
                    names.add(ch)
                    if self.pos[dofs[ax]] >= 0:
                        raise SceneError(f"controls[{i}]: coordinate {ax} of {c.member}@{c.at!r} is not fixed")
                    self.channels.append(ch)
                    self._chan_coord.append(int(dofs[ax]))
                    self._chan_axis.append(ax)
                    self._chan_support.append((c.member, node))
            elif isinstance(c, PointForce):
                if c.member not in sc.members:
                    raise SceneError(f"controls[{i}]: member {c.member!r} does not exist; members: "
                                     f"{sorted(sc.members)}")
                sc._check_at(c.member, c.at, node_only=False, field_name=f"controls[{i}].at")
                from .loads import point_force
                from .scene import _vector
                d = _vector(f"controls[{i}].direction", c.direction, dim)
                if np.linalg.norm(d) == 0:
                    raise SceneError(f"controls[{i}].direction must not be zero")
                if c.name in names:
                    raise SceneError(f"controls[{i}]: name {c.name!r} used twice")
                names.add(c.name)
                mm = a.mesh.members[c.member]
                s = float(c.at) if isinstance(c.at, float) else float(mm.s_node[mm.node(c.at)])
                idx, val = point_force(mm, s, d / np.linalg.norm(d))
                vec = np.zeros(self.n)
                np.add.at(vec, idx, val)
                self.force_names.append(c.name)
                self._force_vecs.append(vec)
            else:
                raise SceneError(f"controls[{i}] must be SupportMotion or PointForce, got {c!r}")
        self.controls = list(controls)
        self.nc, self.nF = len(self.channels), len(self.force_names)
        self.nu = self.nc + self.nF
        self._acc_index = list(range(self.nc))
        self._force_index = list(range(self.nc, self.nu))
        B = np.zeros((self.n, self.nc))
        for k, cd in enumerate(self._chan_coord):
            B[cd, k] = 1.0
        self.B = B
        # rigid translation fields of each channel's axis (position coordinates of every node)
        Tr = np.zeros((self.n, self.nc))
        for mm in a.mesh.members.values():
            for node in range(mm.n_nodes):
                d = mm.node_dofs(node)
                for k, ax in enumerate(self._chan_axis):
                    Tr[d[ax], k] = 1.0
        self.Tr = Tr
        M = a.mass_matrix().tocsc()
        self.M_full = M
        self.Mff = (part.E.T @ M @ part.E).tocsc()
        self.Mfc = (part.E.T @ M @ sp.csc_matrix(B)).tocsc()
        # constant forces: linear energy terms (gravity, distributed dead loads) and dead point loads incl. weights
        f_lin = a.Q.copy()
        for mk in a.mapped:
            if mk.term.effect in LINEAR_EFFECTS:
                mk(a.x0)
                f_lin -= np.bincount(mk.term.idx.ravel(), mk.G.ravel(), minlength=self.n)
        self.f_lin_full = f_lin
        self.f_lin = part.E.T @ f_lin
        self.Bf = part.E.T @ np.column_stack(self._force_vecs) if self.nF else np.zeros((self.nf, 0))
        self.nonlinear = [mk for mk in a.mapped if mk.term.effect not in LINEAR_EFFECTS]
        for mk in self.nonlinear:
            t = mk.term
            if not registry.has_third_derivatives(t.element, t.effect, t.gauss):
                raise SceneError(f"{t.element}/{t.effect} (gauss {t.gauss}) has no third-derivative kernel, which the "
                                 f"exact Hessian needs; available: {list(registry.THIRD_DERIVATIVE_EFFECTS)} at the "
                                 "default quadrature")
        self.length_scale = max(float(mm.member.length) for mm in a.mesh.members.values())

    def variable_names(self) -> list[str]:
        out = []
        for ch in self.channels:
            out += [f"{ch}.position", f"{ch}.velocity", f"{ch}.acceleration"]
        return out + [f"{f}.force" for f in self.force_names]

    def _check_bounds(self, bounds: dict) -> dict:
        if not isinstance(bounds, dict):
            raise SceneError(f"bounds must be a dict name -> (lower, upper), got {bounds!r}")
        known = self.variable_names()
        out = {}
        for k, v in bounds.items():
            if k not in known:
                raise SceneError(f"bounds: unknown name {k!r}; known: {known}")
            if not isinstance(v, (tuple, list)) or len(v) != 2:
                raise SceneError(f"bounds[{k!r}] must be (lower, upper), got {v!r}")
            lo = -np.inf if v[0] is None else float(v[0])
            hi = np.inf if v[1] is None else float(v[1])
            if math.isnan(lo) or math.isnan(hi) or lo > hi:
                raise SceneError(f"bounds[{k!r}] = {tuple(v)!r} is infeasible: lower > upper")
            if k.endswith(".velocity") and not lo <= 0 <= hi:
                raise SceneError(f"bounds[{k!r}] = {tuple(v)!r} excludes rest (velocity 0), where the motion starts")
            out[k] = (lo, hi)
        return out

    def _check_targets(self, d: dict, label: str) -> dict:
        if not isinstance(d, dict):
            raise SceneError(f"{label} must be a dict channel.position -> value, got {d!r}")
        out = {ch: 0.0 for ch in self.channels}
        for k, v in d.items():
            name, _, what = k.rpartition(".")
            if name not in self.channels or what != "position":
                raise SceneError(f"{label}: unknown name {k!r}; give '<channel>.position' for channels "
                                 f"{self.channels} (controlled supports); the scene starts and ends at rest")
            out[name] = _num(f"{label}[{k!r}]", v)
        for ch, val in out.items():
            lo, hi = self.bounds.get(f"{ch}.position", (-np.inf, np.inf))
            if not lo <= val <= hi:
                raise SceneError(f"{label}: {ch}.position = {val} lies outside its bounds ({lo}, {hi}): infeasible")
        return out

    def _check_feasible(self) -> None:
        """Necessary conditions of a rest-to-rest move in the longest allowed time: distance <= v_max T and
        <= a_max T^2 / 4."""
        T = self.T_bounds[1]
        for ch in self.channels:
            d = abs(self.end_values[ch] - self.start_values[ch])
            vlo, vhi = self.bounds.get(f"{ch}.velocity", (-np.inf, np.inf))
            alo, ahi = self.bounds.get(f"{ch}.acceleration", (-np.inf, np.inf))
            vmax = -vlo if self.end_values[ch] < self.start_values[ch] else vhi
            amax = min(-alo, ahi)
            if d > 0 and vmax <= 0:
                raise SceneError(f"{ch}: velocity bounds {(vlo, vhi)} forbid moving from {self.start_values[ch]} "
                                 f"to {self.end_values[ch]}: infeasible")
            if d > vmax * T * (1 + 1e-12):
                raise SceneError(f"{ch}: moving {d} m needs more than the horizon {T} s at the velocity bound "
                                 f"{vmax} m/s: infeasible")
            if amax < 0:
                raise SceneError(f"{ch}: acceleration bounds {(alo, ahi)} exclude zero (rest): infeasible")
            if d > amax * T * T / 4 * (1 + 1e-12):
                raise SceneError(f"{ch}: a rest-to-rest move of {d} m in {T} s needs an acceleration of at least "
                                 f"{4 * d / T ** 2:.4g} m/s^2, above the bound {amax}: infeasible")

    def _chan_vector(self, values: dict) -> np.ndarray:
        return np.array([values[ch] for ch in self.channels], float)

    def _translated(self, q: np.ndarray, ds: np.ndarray) -> np.ndarray:
        """Free coordinates of the scene translated with the supports by ds (exact for single-support scenes)."""
        return q + self.part.E.T @ (self.Tr @ ds) if self.nc else q.copy()

    # -- point functions (one instant) -----------------------------------------------------------------------
    def full(self, q: np.ndarray, s: np.ndarray) -> np.ndarray:
        return self.part.E @ q + self.part.c + self.B @ s

    def _build_point_functions(self) -> None:
        """forces(q, s) -> (grad_f U, K_ff, K_fc) at one instant (Newton for the equilibria, modes)."""
        nf, n = self.nf, self.n
        q, s = ca.MX.sym("q", nf), ca.MX.sym("s", self.nc)
        x = ca.mtimes(_dm(self.part.E), q) + ca.DM(self.part.c) + (ca.mtimes(ca.DM(self.B), s) if self.nc else 0)
        g = ca.MX.zeros(n)
        Ks = []
        for mk in self.nonlinear:
            t = mk.term
            Xe = ca.reshape(x[t.idx.ravel().tolist()], mk.nd, mk.N)
            _, G, H = mk.kernel.map(mk.N)(Xe, ca.DM(mk.P.T))
            Ag = sp.coo_matrix((np.ones(t.idx.size), (t.idx.ravel(), np.arange(t.idx.size))), shape=(n, t.idx.size))
            g += ca.mtimes(_dm(Ag), ca.vec(G))
            ia = np.broadcast_to(t.idx[:, :, None], (mk.N, mk.nd, mk.nd)).ravel()
            ib = np.broadcast_to(t.idx[:, None, :], (mk.N, mk.nd, mk.nd)).ravel()
            Ks.append(_scatter(n, n, ib, ia, ia.size, np.arange(ia.size), ca.vec(H)))
        K = sum(Ks[1:], Ks[0]) if Ks else ca.MX(n, n)
        Ed = _dm(self.part.E)
        gf = ca.mtimes(Ed.T, g)
        Kff = ca.mtimes(ca.mtimes(Ed.T, K), Ed)
        Kfc = ca.mtimes(ca.mtimes(Ed.T, K), ca.DM(self.B)) if self.nc else ca.MX(nf, 0)
        self.forces_f = ca.Function("control_forces", [q, s], [gf, Kff, Kfc], ["q", "s"], ["g", "Kff", "Kfc"])

    def forces(self, q: np.ndarray, s: np.ndarray):
        g, Kff, Kfc = self.forces_f(q, s)
        return np.asarray(g).ravel(), sp.csc_matrix(Kff.sparse()), np.asarray(Kfc)

    def equilibrium(self, s: np.ndarray, guess: np.ndarray | None = None, max_iter: int = 60) -> np.ndarray:
        """Static equilibrium of the free coordinates with the controlled supports displaced by s (Newton with
        a backtracking line search on the residual; from the reference state unless a guess is given)."""
        if guess is None:
            q = self._translated(self.asm.x0[self.part.roots].copy(), s)
        else:
            q = np.asarray(guess, float).copy()
        fscale = max(float(np.max(np.abs(self.f_lin))), 1e-300)
        for it in range(max_iter):
            g, K, _ = self.forces(q, s)
            r = g - self.f_lin
            rn = float(np.max(np.abs(r)))
            if rn <= 1e-10 * fscale + 1e-12:
                return q
            try:
                dq = sp.linalg.spsolve(K.tocsc(), -r)
            except Exception:  # noqa: BLE001
                dq = np.full_like(q, np.nan)
            if not np.all(np.isfinite(dq)):
                break
            lam = 1.0
            for _ in range(30):
                qn = q + lam * dq
                gn = self.forces(qn, s)[0]
                if np.all(np.isfinite(gn)) and np.max(np.abs(gn - self.f_lin)) < (1 - 1e-4 * lam) * rn:
                    break
                lam *= 0.5
            q = qn
        g = self.forces(q, s)[0]
        rn = float(np.max(np.abs(g - self.f_lin)))
        if rn <= 1e-7 * fscale:
            return q
        raise SceneError(f"no static equilibrium found for support displacements {s.tolist()} (residual {rn:.3g} N "
                         f"after {max_iter} Newton iterations): the start/end state cannot be at rest")

    def _modes(self, q: np.ndarray, s: np.ndarray):
        """Natural frequencies [rad/s] and M-orthonormal modes of the free coordinates about (q, s)."""
        _, K, _ = self.forces(q, s)
        Kd = K.toarray()
        Kd = 0.5 * (Kd + Kd.T)
        w2, Phi = sla.eigh(Kd, self.Mff.toarray())
        return np.sqrt(np.maximum(w2, 0.0)), Phi

    def end_mode_count(self) -> int:
        omega = self.modes[0]
        if self.end_modes is not None:
            return min(int(self.end_modes), self.nf)
        f_cut = self.end_frequency if self.end_frequency is not None else self.K / (4.0 * self.T_bounds[1])
        return max(1, int(np.sum(omega < 2 * np.pi * f_cut)))

    # -- probes -----------------------------------------------------------------------------------------------
    def _probe(self, member: str, at: Any):
        """(idx (dim, 4) global coordinates, weights (4,)) with r(s) = x[idx] @ w."""
        sc = self.scene
        sc._check_at(member, at, node_only=False, field_name="point.at")
        mm = self.asm.mesh.members[member]
        s = float(at) if isinstance(at, float) else float(mm.s_node[mm.node(at)])
        e, xi = mm.locate(s)
        L = mm.elem_length[e]
        n0, n1 = mm.elem_nodes[e]
        h = hermite.h(xi)
        dim, ns = sc.dim, mm.node_size
        b0, b1 = mm.offset + n0 * ns, mm.offset + n1 * ns
        idx = np.array([[b0 + k, b0 + dim + k, b1 + k, b1 + dim + k] for k in range(dim)])
        return idx, np.array([h[0], L * h[1], h[2], L * h[3]])

    # -- the NLP --------------------------------------------------------------------------------------------------
    def _layout(self) -> None:
        """Decision vector, interval after interval: [q_0 | v_k, s_k, s'_k, Q_k (s x nf), SP_k, SV_k, U_k
        (s x ...), q_k+1 (Gauss only) | ... | v_K, s_K, s'_K | T]. Radau's last stage is the interval's end, so
        q_k+1 is that stage's variable (no separate copy, no continuity row)."""
        K, s, nf, nc, nu = self.K, self.s, self.nf, self.nc, self.nu
        radau = self.tab.stiffly_accurate
        counter = [0]

        def take(*shape):
            size = int(np.prod(shape))
            out = np.arange(counter[0], counter[0] + size, dtype=np.int64).reshape(shape)
            counter[0] += size
            return out
        iq, iv = np.zeros((K + 1, nf), np.int64), np.zeros((K + 1, nf), np.int64)
        isb, isvb = np.zeros((K + 1, nc), np.int64), np.zeros((K + 1, nc), np.int64)
        iQ, iSP, iSV = np.zeros((K, s, nf), np.int64), np.zeros((K, s, nc), np.int64), np.zeros((K, s, nc), np.int64)
        iU = np.zeros((K, s, nu), np.int64)
        iq[0] = take(nf)
        for k in range(K):
            iv[k], isb[k], isvb[k] = take(nf), take(nc), take(nc)
            iQ[k], iSP[k], iSV[k] = take(s, nf), take(s, nc), take(s, nc)
            iU[k] = take(s, nu) if self.control_form == "polynomial" else np.broadcast_to(take(1, nu), (s, nu))
            iq[k + 1] = iQ[k, s - 1] if radau else take(nf)
        iv[K], isb[K], isvb[K] = take(nf), take(nc), take(nc)
        self.iT = int(take(1)[0]) if self.free_time else None
        self.nw = counter[0]
        self.idx = {"q": iq, "v": iv, "s": isb, "sv": isvb, "Q": iQ, "SP": iSP, "SV": iSV, "U": iU}

    def _build_nlp(self) -> None:
        K, s, nf, nc, nu, n = self.K, self.s, self.nf, self.nc, self.nu, self.n
        tab = self.tab
        self.tau = np.r_[0.0, tab.c]
        self.Pp = Pp = K * s
        self.nz = 2 * nf + 2 * nc
        self.Nn = K * (s + 1) + 1
        self._layout()
        nw, I = self.nw, self.idx
        w = ca.MX.sym("w", nw)

        def mat(ix):  # MX (last dim x rest) of w at an index array
            m = ix.shape[-1]
            cols = ix.size // m if m else int(np.prod(ix.shape[:-1]))
            if m == 0:
                return ca.MX(0, cols)
            return ca.reshape(w[ix.reshape(-1).tolist()], m, cols)
        T = w[self.iT] if self.free_time else ca.DM(self.T_guess)
        h = T / K
        W = np.linalg.inv(tab.A)
        IK = sp.identity(K, format="csc")
        Wbig = _dm(sp.kron(IK, sp.csc_matrix(W.T)))  # (Ks x Ks): (X Wbig)[:, k s + j] = sum_m X[:, k s + m] W[j, m]
        Abig = _dm(sp.kron(IK, sp.csc_matrix(tab.A.T)))
        Rw1 = _dm(sp.kron(IK, sp.csc_matrix(W.sum(axis=1)[None, :])))  # (K x Ks): value at the interval start x w1_j
        R1 = _dm(sp.kron(IK, sp.csc_matrix(np.ones((1, s)))))
        Bk = _dm(sp.kron(IK, sp.csc_matrix(tab.b[:, None])))  # (Ks x K): quadrature over each interval
        q0, v0 = mat(I["q"][:-1]), mat(I["v"][:-1])
        q1, v1 = mat(I["q"][1:]), mat(I["v"][1:])
        s0, sv0, s1, sv1 = mat(I["s"][:-1]), mat(I["sv"][:-1]), mat(I["s"][1:]), mat(I["sv"][1:])
        Qm, SP, SV, U = mat(I["Q"]), mat(I["SP"]), mat(I["SV"]), mat(I["U"])
        Ua, Uf = U[:nc, :], U[nc:, :]
        # stage velocities and accelerations of the implicit Runge-Kutta form (W = A^-1)
        Vst = (ca.mtimes(Qm, Wbig) - ca.mtimes(q0, Rw1)) / h
        Acc = (ca.mtimes(Vst, Wbig) - ca.mtimes(v0, Rw1)) / h
        self._Vst_fun = ca.Function("stage_velocities", [w], [Vst])
        dyn = ca.mtimes(_dm(self.Mff), Acc) - ca.repmat(ca.DM(self.f_lin), 1, Pp)
        if nc:
            dyn += ca.mtimes(_dm(self.Mfc), Ua)
        if self.nF:
            dyn -= ca.mtimes(ca.DM(self.Bf), Uf)
        rows = [ca.vec(dyn)]
        if nc:
            rows += [ca.vec(SV - ca.mtimes(sv0, R1) - h * ca.mtimes(Ua, Abig)),
                     ca.vec(SP - ca.mtimes(s0, R1) - h * ca.mtimes(SV, Abig))]
        if not tab.stiffly_accurate:
            rows.append(ca.vec(q1 - q0 - h * ca.mtimes(Vst, Bk)))
        rows.append(ca.vec(v1 - v0 - h * ca.mtimes(Acc, Bk)))
        if nc:
            rows += [ca.vec(s1 - s0 - h * ca.mtimes(SV, Bk)), ca.vec(sv1 - sv0 - h * ca.mtimes(Ua, Bk))]
        n_dyn = sum(r.shape[0] for r in rows)
        # terminal: the scene at rest at its end equilibrium on the chosen modes
        self._end_rows = 0
        if self.end_rest:
            nm = self.end_mode_count()
            PM = ca.DM(self.modes[1][:, :nm].T @ self.Mff.toarray())
            rows += [ca.mtimes(PM, w[I["q"][K].tolist()] - ca.DM(self.q_end)), ca.mtimes(PM, w[I["v"][K].tolist()])]
            self._end_rows = 2 * nm
            self.n_end_modes = nm
        else:
            self.n_end_modes = 0
        Ed = _dm(self.part.E)
        Xp = ca.mtimes(Ed, Qm) + ca.repmat(ca.DM(self.part.c), 1, Pp)
        Vp = ca.mtimes(Ed, Vst)
        if nc:
            Xp += ca.mtimes(ca.DM(self.B), SP)
            Vp += ca.mtimes(ca.DM(self.B), SV)
        # path constraints at the collocation points, terminal constraints at T
        lb_path, ub_path = [], []
        items = [("path", i, pc) for i, pc in enumerate(self.path)] + \
            [("terminal", i, pc) for i, pc in enumerate(self.terminal)]
        if items:
            xs, vs = ca.MX.sym("x", n), ca.MX.sym("v", n)
            ps_, vs_, us_ = ca.MX.sym("sp", nc), ca.MX.sym("sv", nc), ca.MX.sym("u", nu)
            view = StateView(self, xs, vs, ps_, vs_, us_)
            xT = ca.mtimes(Ed, w[I["q"][K].tolist()]) + ca.DM(self.part.c)
            vT = ca.mtimes(Ed, w[I["v"][K].tolist()])
            if nc:
                xT += ca.mtimes(ca.DM(self.B), w[I["s"][K].tolist()])
                vT += ca.mtimes(ca.DM(self.B), w[I["sv"][K].tolist()])
            for kind, i, pc in items:
                label = f"{kind}[{i}] ({pc.name!r})"
                try:
                    expr = ca.vec(ca.MX(pc.fn(view)))
                except SceneError:
                    raise
                except Exception as exc:  # noqa: BLE001
                    raise SceneError(f"{label}: fn(view) failed: {exc}") from None
                if not ca.depends_on(expr, ca.vertcat(xs, vs, ps_, vs_, us_)):
                    raise SceneError(f"{label}: fn(view) does not depend on the state")
                m = expr.shape[0]
                lo = np.broadcast_to(np.asarray(pc.lower, float), (m,))
                hi = np.broadcast_to(np.asarray(pc.upper, float), (m,))
                if np.any(np.isnan(lo)) or np.any(np.isnan(hi)) or np.any(lo > hi):
                    raise SceneError(f"{label}: bounds ({pc.lower}, {pc.upper}) are infeasible (lower > upper)")
                fn = ca.Function(f"{kind}_{i}", [xs, vs, ps_, vs_, us_], [expr])
                if kind == "path":
                    rows.append(ca.vec(fn.map(Pp)(Xp, Vp, SP, SV, U)))
                    reps = Pp
                else:  # the controls of the last collocation point
                    rows.append(fn(xT, vT, w[I["s"][K].tolist()] if nc else ca.MX(0, 1),
                                   w[I["sv"][K].tolist()] if nc else ca.MX(0, 1), U[:, Pp - 1]))
                    reps = 1
                lb_path.append(np.tile(lo, reps))
                ub_path.append(np.tile(hi, reps))
        g_poly = ca.vertcat(*rows)
        ng = g_poly.shape[0]
        self.ng = ng
        n_eq = n_dyn + self._end_rows
        self.lbg = np.r_[np.zeros(n_eq), *(lb_path or [np.zeros(0)])]
        self.ubg = np.r_[np.zeros(n_eq), *(ub_path or [np.zeros(0)])]
        self._g_rows = {"dynamics": (0, nf * Pp), "collocation": (0, n_dyn), "end": (n_dyn, n_eq),
                        "path": (n_eq, ng)}  # path: path and terminal constraints
        # -- cost ------------------------------------------------------------------------------------------------
        bw = ca.DM(np.tile(tab.b, K))  # quadrature weights of the points (times h)
        f = 0
        for c in self.cost:
            if isinstance(c, Effort):
                wts = np.ones(nu)
                names = self.channels + self.force_names
                for k2, v2 in (c.weights or {}).items():
                    if k2 not in names:
                        raise SceneError(f"Effort.weights: unknown control {k2!r}; known: {names}")
                    wts[names.index(k2)] = _num(f"Effort.weights[{k2!r}]", v2, nonneg=True)
                f += c.weight * h * ca.mtimes(ca.mtimes(ca.DM(wts).T, U ** 2), bw)
            elif isinstance(c, MinimumTime):
                f += c.weight * T
            elif isinstance(c, Swing):
                Vrel = ca.mtimes(Ed, Vst)
                if nc:
                    Vrel += ca.mtimes(ca.DM(self.B - self.Tr), SV)
                ke = 0.5 * ca.sum1(Vrel * ca.mtimes(_dm(self.M_full), Vrel))
                f += c.weight * h * ca.mtimes(ke, bw)
        f = ca.MX(f) if not isinstance(f, ca.MX) else f
        # -- kernels at all points: g, Jacobian, Hessian of the Lagrangian ----------------------------------------
        Xv = ca.vec(Xp)
        lam_g, lam_f = ca.MX.sym("lam_g", ng), ca.MX.sym("lam_f")
        iQf, iSPf = I["Q"].reshape(Pp, nf), I["SP"].reshape(Pp, nc)
        g_parts, jac_rows, jac_cols, jac_keep = [], [], [], []
        hess_rows, hess_cols, hess_keep, dh_vals = [], [], [], []
        self._kernel_calls = []
        n_jac = 0
        for mk in self.nonlinear:
            t = mk.term
            N, nd = mk.N, mk.nd
            M = Pp * N
            idx_all = (t.idx[None, :, :] + n * np.arange(Pp)[:, None, None]).reshape(M, nd)
            coord = np.tile(t.idx, (Pp, 1))  # (M, nd) scene coordinate of each element entry
            pnt = np.repeat(np.arange(Pp), N)  # collocation point of each mapped column
            Xe = ca.reshape(Xv[idx_all.ravel().tolist()], nd, M)
            Pm = ca.DM(np.tile(mk.P, (Pp, 1)).T)
            main = mk.kernel.map(M)
            efun = kernels.load_energy(t.element, t.effect, t.gauss)
            Xs = ca.MX.sym("Xe", nd, M)
            gfun = ca.Function(f"grad_{t.element}_{t.effect}", [Xs],
                               [ca.gradient(ca.sum2(efun.map(M)(Xs, Pm)), Xs)])
            hvp = kernels.load_hvp(t.element, t.effect).map(M)
            self._kernel_calls.append((main, gfun, hvp, idx_all, Pm))
            pos_c = self.pos[coord]
            a_row = np.where(pos_c >= 0, pnt[:, None] * nf + np.maximum(pos_c, 0), -1)  # dynamics row
            a_var = np.full(coord.shape, -1, dtype=np.int64)  # decision variable
            a_var[pos_c >= 0] = iQf[np.broadcast_to(pnt[:, None], coord.shape)[pos_c >= 0], pos_c[pos_c >= 0]]
            for k2, cd in enumerate(self._chan_coord):
                hit = coord == cd
                a_var[hit] = iSPf[np.broadcast_to(pnt[:, None], coord.shape)[hit], k2]
            r_flat = a_row.ravel()  # vec(G) entry col * nd + a
            ok = np.flatnonzero(r_flat >= 0)
            Ag = _dm(sp.coo_matrix((np.ones(len(ok)), (r_flat[ok], ok)), shape=(ng, M * nd)))
            g_parts.append((Ag, gfun, main, Xe, Pm))
            # Jacobian: vec(H) entry (col * nd + a) * nd + b -> (row of b, variable of a)
            rb = np.broadcast_to(a_row[:, None, :], (M, nd, nd)).ravel()
            va = np.broadcast_to(a_var[:, :, None], (M, nd, nd)).ravel()
            keep = np.flatnonzero((rb >= 0) & (va >= 0))
            jac_rows.append(rb[keep])
            jac_cols.append(va[keep])
            jac_keep.append(keep + n_jac)
            # Hessian: v = the dynamics multipliers at each element coordinate; d(H v)/dq (symmetric) -> upper
            Vsel = _dm(sp.coo_matrix((np.ones(len(ok)), (ok, r_flat[ok])), shape=(M * nd, ng)))
            vmat = ca.reshape(ca.mtimes(Vsel, lam_g), nd, M)
            hr = np.broadcast_to(a_var[:, :, None], (M, nd, nd)).ravel()
            hc = np.broadcast_to(a_var[:, None, :], (M, nd, nd)).ravel()
            keep = np.flatnonzero((hr >= 0) & (hc >= 0) & (hr <= hc))
            hess_rows.append(hr[keep])
            hess_cols.append(hc[keep])
            hess_keep.append(keep + n_jac)
            dh_vals.append(ca.vec(hvp(Xe, Pm, vmat)[1]))
            n_jac += M * nd * nd
        zero = ca.MX(ng, 1)
        # g for IPOPT's function evaluations: gradients from the energy kernels' reverse companions (cheaper)
        g_kernel = sum((ca.mtimes(Ag, ca.vec(gf(Xe))) for Ag, gf, _, Xe, _ in g_parts), zero)
        # g and its Jacobian from the full kernels (one call gives both)
        outs = [main(Xe, Pm) for _, _, main, Xe, Pm in g_parts]
        g_kernel_full = sum((ca.mtimes(Ag, ca.vec(o[1])) for (Ag, *_), o in zip(g_parts, outs)), zero)
        if outs:
            J_kernel = _scatter(ng, nw, np.concatenate(jac_rows), np.concatenate(jac_cols), n_jac,
                                np.concatenate(jac_keep), ca.vertcat(*[ca.vec(o[2]) for o in outs]))
            H_kernel = _scatter(nw, nw, np.concatenate(hess_rows), np.concatenate(hess_cols), n_jac,
                                np.concatenate(hess_keep), ca.vertcat(*dh_vals))
        else:
            J_kernel, H_kernel = ca.MX(ng, nw), ca.MX(nw, nw)
        g_nlp = g_poly + g_kernel
        self.nlp = {"x": w, "f": f, "g": g_nlp}
        p0 = ca.MX.sym("p", 0)
        self.jac_g = ca.Function("nlp_jac_g", [w, p0], [g_poly + g_kernel_full, ca.jacobian(g_poly, w) + J_kernel],
                                 ["x", "p"], ["g", "jac_g_x"])
        lag_poly = lam_f * f + ca.dot(lam_g, g_poly)
        H_poly = ca.triu(ca.hessian(lag_poly, w)[0])
        self.hess_lag = ca.Function("nlp_hess_l", [w, p0, lam_f, lam_g], [H_poly + H_kernel],
                                    ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"])
        self.g_function = ca.Function("g", [w], [g_nlp])
        self.f_function = ca.Function("f", [w], [f])
        self._lbx, self._ubx = self._variable_bounds()

    # -- variable layout ----------------------------------------------------------------------------------------
    def _variable_bounds(self):
        I, K, nf, nc = self.idx, self.K, self.nf, self.nc
        lb, ub = np.full(self.nw, -np.inf), np.full(self.nw, np.inf)
        for k, ch in enumerate(self.channels):
            lo, hi = self.bounds.get(f"{ch}.position", (-np.inf, np.inf))
            for key in ("s", "SP"):
                lb[I[key][..., k]], ub[I[key][..., k]] = lo, hi
            lo, hi = self.bounds.get(f"{ch}.velocity", (-np.inf, np.inf))
            for key in ("sv", "SV"):
                lb[I[key][..., k]], ub[I[key][..., k]] = lo, hi
            lb[I["U"][..., k]], ub[I["U"][..., k]] = self.bounds.get(f"{ch}.acceleration", (-np.inf, np.inf))
        for k, fn in enumerate(self.force_names):
            lb[I["U"][..., nc + k]], ub[I["U"][..., nc + k]] = self.bounds.get(f"{fn}.force", (-np.inf, np.inf))
        # start: at rest in equilibrium; end: supports at rest at their targets
        s0, sT = self._chan_vector(self.start_values), self._chan_vector(self.end_values)
        for key, val in (("q", self.q_start), ("v", np.zeros(nf)), ("s", s0), ("sv", np.zeros(nc))):
            lb[I[key][0]], ub[I[key][0]] = val, val
        for key, val in (("s", sT), ("sv", np.zeros(nc))):
            lb[I[key][K]], ub[I[key][K]] = val, val
        if self.free_time:
            lb[self.iT], ub[self.iT] = self.T_bounds
        return lb, ub

    def pack(self, Z: np.ndarray, U: np.ndarray, T: float | None = None) -> np.ndarray:
        """Decision vector from node states Z (Nn x [q, v, s, s']) at the node times (interval starts and the
        collocation points, then the end) and the controls U (Pp x nu) at the collocation points."""
        I, K, s, nf, nc = self.idx, self.K, self.s, self.nf, self.nc
        Z = np.asarray(Z, float).reshape(self.Nn, self.nz)
        w = np.zeros(self.nw)
        starts = np.r_[np.arange(K) * (s + 1), self.Nn - 1]
        stages = (np.arange(K)[:, None] * (s + 1) + np.arange(1, s + 1)[None, :]).ravel()
        for key, sl in (("q", slice(0, nf)), ("v", slice(nf, 2 * nf)), ("s", slice(2 * nf, 2 * nf + nc)),
                        ("sv", slice(2 * nf + nc, None))):
            w[I[key][:-1].ravel()] = Z[starts[:-1], sl].ravel()
        for key, sl in (("Q", slice(0, nf)), ("SP", slice(2 * nf, 2 * nf + nc)), ("SV", slice(2 * nf + nc, None))):
            w[I[key].reshape(-1)] = Z[stages, sl].ravel()
        for key, sl in (("q", slice(0, nf)), ("v", slice(nf, 2 * nf)), ("s", slice(2 * nf, 2 * nf + nc)),
                        ("sv", slice(2 * nf + nc, None))):
            if key != "q" or not self.tab.stiffly_accurate:
                w[I[key][-1]] = Z[-1, sl]
        w[I["U"].reshape(-1)] = np.asarray(U, float).ravel()
        if self.free_time:
            w[self.iT] = T if T is not None else self.T_guess
        return w

    def unpack(self, w: np.ndarray):
        """(Z, U, T): node states Z (Nn x [q, v, s, s']) with the stage velocities from the Runge-Kutta
        relations, controls U (Pp x nu) at the collocation points, horizon T."""
        I, K, s, nf = self.idx, self.K, self.s, self.nf
        w = np.asarray(w, float).ravel()
        Z = np.zeros((self.Nn, self.nz))
        Vst = np.asarray(self._Vst_fun(w)).reshape(nf, self.Pp).T if nf else np.zeros((self.Pp, 0))
        for k in range(K + 1):
            r = k * (s + 1) if k < K else self.Nn - 1
            Z[r] = np.r_[w[I["q"][k]], w[I["v"][k]], w[I["s"][k]], w[I["sv"][k]]]
            if k == K:
                break
            for j in range(s):
                Z[r + 1 + j] = np.r_[w[I["Q"][k, j]], Vst[k * s + j], w[I["SP"][k, j]], w[I["SV"][k, j]]]
        U = w[I["U"].reshape(-1)].reshape(self.Pp, self.nu)
        T = float(w[self.iT]) if self.free_time else self.T_guess
        return Z, U, T

    def node_times(self, T: float) -> np.ndarray:
        h = T / self.K
        t = (np.arange(self.K)[:, None] + self.tau[None, :]).ravel() * h
        return np.r_[t, T]

    def point_times(self, T: float) -> np.ndarray:
        h = T / self.K
        return (np.arange(self.K)[:, None] + self.tab.c[None, :]).ravel() * h

    # -- warm start -------------------------------------------------------------------------------------------
    def naive_motion(self, T: float):
        """Smooth rest-to-rest support motion (quintic, zero velocity and acceleration at both ends): a function
        of t giving (s, s', s'') arrays (len(t) x channels)."""
        s0, sT = self._chan_vector(self.start_values), self._chan_vector(self.end_values)
        d = sT - s0

        def motion(t):
            x = np.clip(np.atleast_1d(np.asarray(t, float)) / T, 0.0, 1.0)
            p = 10 * x**3 - 15 * x**4 + 6 * x**5
            dp = (30 * x**2 - 60 * x**3 + 30 * x**4) / T
            ddp = (60 * x - 180 * x**2 + 120 * x**3) / T**2
            return s0 + np.multiply.outer(p, d), np.multiply.outer(dp, d), np.multiply.outer(ddp, d)
        return motion

    def guess_from_trajectory(self, T: float, q_of_t: Callable, v_of_t: Callable, motion: Callable,
                              forces: Callable | None = None) -> np.ndarray:
        """Decision vector from free coordinates q_of_t(t) and velocities v_of_t(t) ((len(t), nf) arrays), the
        support motion motion(t) -> (s, s', s'') and the controlled forces forces(t) -> (len(t), nF)."""
        nf, nc = self.nf, self.nc
        tn = self.node_times(T)
        Z = np.zeros((self.Nn, self.nz))
        Z[:, :nf], Z[:, nf:2 * nf] = q_of_t(tn), v_of_t(tn)
        sp_, sv_, _ = motion(tn)
        Z[:, 2 * nf:2 * nf + nc], Z[:, 2 * nf + nc:] = sp_, sv_
        tp = self.point_times(T)
        U = np.zeros((self.Pp, self.nu))
        if nc:
            U[:, :nc] = motion(tp)[2]
        if self.nF and forces is not None:
            U[:, nc:] = forces(tp)
        return self.pack(Z, U, T)

    def collocation_simulation(self, T: float, controls: np.ndarray, max_iter: int = 20):
        """Integrate the scene with the OCP's own collocation equations for given point controls (Pp x nu), from
        the start state: each interval's stage equations solved by Newton on their exact sparse Jacobian.
        Returns (decision vector, converged?, message); the vector satisfies every dynamics row the NLP has."""
        K, s, nf, nc = self.K, self.s, self.nf, self.nc
        tab = self.tab
        h = T / K
        W = np.linalg.inv(tab.A)
        W2, w1 = W @ W, W.sum(axis=1)
        w21 = W2.sum(axis=1)
        U = np.asarray(controls, float).reshape(self.Pp, self.nu)
        Mff, Mfc = self.Mff, self.Mfc
        Z = np.zeros((self.Nn, self.nz))
        q, v = self.q_start.copy(), np.zeros(nf)
        sc, svc = self._chan_vector(self.start_values), np.zeros(nc)
        fscale = max(float(np.max(np.abs(self.f_lin))), 1e-300)
        Qs = np.tile(q, (s, 1))
        message = ""
        ok_all = True
        for k in range(K):
            Uk = U[k * s:(k + 1) * s]
            Ua, Uf = Uk[:, :nc], Uk[:, nc:]
            SV = svc[None, :] + h * tab.A @ Ua
            SP = sc[None, :] + h * tab.A @ SV
            rhs_const = np.zeros((s, nf))
            for j in range(s):
                rhs_const[j] = Mff @ (-w21[j] * q / h**2 - w1[j] * v / h) - self.f_lin
                if nc:
                    rhs_const[j] += Mfc @ Ua[j]
                if self.nF:
                    rhs_const[j] -= self.Bf @ Uf[j]
            if k == 0:
                Qs = np.array([q + tab.c[j] * h * v for j in range(s)])
            ok = False

            def residual(Qs):
                R = np.zeros((s, nf))
                Ks = []
                for j in range(s):
                    g, Kj, _ = self.forces(Qs[j], SP[j])
                    R[j] = rhs_const[j] + g + Mff @ (W2[j] @ Qs) / h**2
                    Ks.append(Kj)
                return R, Ks
            R, Ks = residual(Qs)
            rn = float(np.max(np.abs(R)))
            for it in range(max_iter):
                if not math.isfinite(rn):
                    break
                if rn <= 1e-9 * fscale:
                    ok = True
                    break
                J = sp.bmat([[W2[j, m] / h**2 * Mff + (Ks[j] if j == m else 0 * Mff) for m in range(s)]
                             for j in range(s)], format="csc")
                try:
                    dQ = sp.linalg.spsolve(J, -R.ravel()).reshape(s, nf)
                except Exception:  # noqa: BLE001
                    break
                if not np.all(np.isfinite(dQ)):
                    break
                lam = 1.0
                for _ in range(20):  # backtrack on the residual (rotations of a stiff cable overshoot)
                    Rn, Kn = residual(Qs + lam * dQ)
                    rnn = float(np.max(np.abs(Rn)))
                    if math.isfinite(rnn) and rnn < (1 - 1e-4 * lam) * rn:
                        break
                    lam *= 0.5
                Qs, R, Ks, rn = Qs + lam * dQ, Rn, Kn, rnn
                if lam == 1.0 and float(np.max(np.abs(dQ))) <= 1e-12 * self.length_scale:
                    ok = True
                    break
            if not ok:
                ok_all = False
                message = f"interval {k}: Newton did not converge (residual {rn:.3g} N)"
                break
            V = (W @ (Qs - q[None, :])) / h
            Acc = (W @ (V - v[None, :])) / h
            r = k * (s + 1)
            Z[r] = np.r_[q, v, sc, svc]
            for j in range(s):
                Z[r + 1 + j] = np.r_[Qs[j], V[j], SP[j], SV[j]]
            nodes_pos = np.r_[q[None, :], Qs]
            q = Qs[-1].copy() if tab.stiffly_accurate else q + h * tab.b @ V
            v = v + h * tab.b @ Acc
            sc, svc = sc + h * tab.b @ SV, svc + h * tab.b @ Ua
            Qs = _basis(self.tau, 1.0 + tab.c) @ nodes_pos  # the interval's polynomial, extrapolated
        if ok_all:
            Z[-1] = np.r_[q, v, sc, svc]
        else:  # hold the last good state
            last = k * (s + 1)
            Z[last:] = np.r_[q, v, sc, svc]
        return self.pack(Z, U, T), ok_all, message

    def warm_start(self):
        """A simulation of the naive (quintic rest-to-rest) support motion with the OCP's own collocation
        equations: every dynamics row holds at the start, only the end conditions are off."""
        T = self.T_guess
        motion = self.naive_motion(T)
        U = np.zeros((self.Pp, self.nu))
        if self.nc:
            U[:, :self.nc] = motion(self.point_times(T))[2]
        w, ok, msg = self.collocation_simulation(T, U)
        return w, {"method": "collocation simulation of a quintic rest-to-rest motion", "converged": ok,
                   "message": msg}

    # -- solve ----------------------------------------------------------------------------------------------------
    def solver(self, full_steps: bool):
        """IPOPT on the NLP with the kernels' Jacobian and Hessian. full_steps: accept every trial step (Newton on
        the KKT conditions; the filter line search crawls along the stiff cable's constraint manifold), else
        IPOPT's line search. MUMPS with AMD ordering and without its column permutation (the default choices were
3-10x slower on the crane: more fill, and more iterations at n = 8, K = 40); adaptive barrier
        parameter (the monotone one needed 200-1000 iterations on minimum-time problems with path constraints, the
        adaptive one 30-40)."""
        key = bool(full_steps)
        if key not in self._solvers:
            ip = {"tol": self.tol, "max_iter": self.max_iter, "print_level": self.print_level, "sb": "yes",
                  "linear_solver": "mumps", "mumps_pivot_order": 0, "mumps_permuting_scaling": 0,
                  "mu_strategy": "adaptive"}
            if full_steps:
                ip["accept_every_trial_step"] = "yes"
                ip["max_iter"] = min(self.max_iter, FULL_STEP_ITERATIONS)
            ip.update(self.ipopt_extra)
            t0 = time.perf_counter()
            self._solvers[key] = ca.nlpsol("ocp", "ipopt", self.nlp, {
                "ipopt": ip, "print_time": False, "jac_g": self.jac_g, "hess_lag": self.hess_lag,
                "no_nlp_grad": True, "calc_lam_p": False, "calc_lam_x": False, "calc_f": False, "calc_g": False,
                "error_on_fail": False})
            self.solver_build_s += time.perf_counter() - t0
        return self._solvers[key]

    def _run(self, w0: np.ndarray, full_steps: bool, lam_g0=None):
        S = self.solver(full_steps)
        args = dict(x0=w0, lbx=self._lbx, ubx=self._ubx, lbg=self.lbg, ubg=self.ubg)
        if lam_g0 is not None:
            args["lam_g0"] = lam_g0
        t0 = time.perf_counter()
        try:
            sol = S(**args)
            st = dict(S.stats())
            w = np.asarray(sol["x"]).ravel()
            lam = np.asarray(sol["lam_g"]).ravel()
            status = st.get("return_status", "unknown")
        except RuntimeError as exc:  # an evaluation error IPOPT could not recover from
            st, w, lam, status = {"error": str(exc)}, w0.copy(), np.zeros(self.ng), "Evaluation_Error"
        wall = time.perf_counter() - t0
        if not np.all(np.isfinite(w)):
            w, status = w0.copy(), f"{status} (non-finite iterate; start point kept)"
        return status, w, lam, st, wall

    def solve(self, guess: Any = None, strategy: str = "auto") -> "ControlResult":
        """Solve from `guess` (decision vector or previous result; default: the warm-start simulation).

        strategy "auto": full steps first, IPOPT's line search from the same guess if they fail; "full_steps" or
        "line_search" alone. A failure returns the attempt that ended closest to feasibility, with its status."""
        if strategy not in ("auto", "full_steps", "line_search"):
            raise SceneError(f"strategy must be 'auto', 'full_steps' or 'line_search', got {strategy!r}")
        t0 = time.perf_counter()
        warm = None
        if guess is None:
            w0, warm = self.warm_start()
        elif isinstance(guess, ControlResult):
            w0 = guess.w.copy()
        else:
            w0 = np.asarray(guess, float).ravel()
            if w0.shape != (self.nw,) or not np.all(np.isfinite(w0)):
                raise SceneError(f"guess must be {self.nw} finite numbers, got shape {np.shape(guess)}")
        warm_s = time.perf_counter() - t0
        w0 = np.clip(w0, self._lbx, self._ubx)
        plan = {"auto": (True, False), "full_steps": (True,), "line_search": (False,)}[strategy]
        attempts, best = [], None
        for full in plan:
            status, w, lam, st, wall = self._run(w0, full)
            viol = self.violation(w)
            attempts.append({"method": "full steps" if full else "line search", "status": status,
                             "iterations": int(st.get("iter_count", 0)), "wall_s": wall, "violation": viol,
                             "calls": {k: v for k, v in st.items() if k.startswith(("n_call_", "t_wall_"))}})
            cand = (status in SUCCESS, -viol, status, w, lam, st, wall)
            if best is None or (cand[0], cand[1]) > (best[0], best[1]):
                best = cand
            if status in SUCCESS:
                break
        ok, _, status, w, lam, st, _ = best
        return ControlResult(self, w, lam, status, ok, st, sum(a["wall_s"] for a in attempts), warm_s, warm,
                             attempts)

    def violations(self, w: np.ndarray) -> dict:
        """Largest violation per group: dynamics rows [N], the other collocation and continuity rows [m, m/s],
        end rows (modal amplitudes [sqrt(kg) m, sqrt(kg) m/s]), path constraints (their units), variable bounds."""
        g = np.asarray(self.g_function(w)).ravel()
        v = np.maximum(self.lbg - g, 0) + np.maximum(g - self.ubg, 0)
        out = {}
        a, b = self._g_rows["dynamics"]
        out["dynamics"] = float(v[a:b].max()) if b > a else 0.0
        a2, b2 = self._g_rows["collocation"]
        out["kinematics"] = float(v[b:b2].max()) if b2 > b else 0.0
        for key in ("end", "path"):
            a, b = self._g_rows[key]
            out[key] = float(v[a:b].max()) if b > a else 0.0
        vb = np.maximum(self._lbx - w, 0) + np.maximum(w - self._ubx, 0)
        out["bounds"] = float(vb.max()) if vb.size else 0.0
        return out

    def violation(self, w: np.ndarray) -> float:
        """Largest violation of the constraints (rows and variable bounds) at w, in their units (N, m, m/s)."""
        g = np.asarray(self.g_function(w)).ravel()
        v = np.r_[np.maximum(self.lbg - g, 0), np.maximum(g - self.ubg, 0), np.maximum(self._lbx - w, 0),
                  np.maximum(w - self._ubx, 0)]
        return float(v.max()) if v.size else 0.0

    def kernel_times(self, w: np.ndarray, repeat: int = 5) -> dict:
        """Seconds per call of the mapped kernels at all collocation points (one pass each): gradient (energy
        reverse companion), full (energy, gradient, Hessian) and third-derivative (hvp) kernels, at the state w."""
        Z, U, T = self.unpack(w)
        stages = (np.arange(self.K)[:, None] * (self.s + 1) + np.arange(1, self.s + 1)[None, :]).ravel()
        Zc = Z[stages]
        X = self.part.E @ Zc[:, :self.nf].T + self.part.c[:, None]
        if self.nc:
            X = X + self.B @ Zc[:, 2 * self.nf:2 * self.nf + self.nc].T
        Xflat = X.T.ravel()  # point after point
        out = {"gradient": 0.0, "full": 0.0, "hvp": 0.0}
        for main, gfun, hvp, idx_all, Pm in self._kernel_calls:
            Xe = np.ascontiguousarray(Xflat[idx_all])  # (M, nd) row-major == (nd, M) column-major
            Pnp = np.ascontiguousarray(np.asarray(Pm).T)
            V = np.ones_like(Xe)
            for key, f, args in (("gradient", gfun, [Xe]), ("full", main, [Xe, Pnp]), ("hvp", hvp, [Xe, Pnp, V])):
                buf, ev = f.buffer()
                res = [np.zeros(f.nnz_out(i)) for i in range(f.n_out())]
                for i, a in enumerate(args):
                    buf.set_arg(i, memoryview(a))
                for i, r in enumerate(res):
                    buf.set_res(i, memoryview(r))
                ev()
                ts = []
                for _ in range(repeat):
                    t0 = time.perf_counter()
                    ev()
                    ts.append(time.perf_counter() - t0)
                out[key] += float(np.median(ts))
        return out


# -- results -----------------------------------------------------------------------------------------------------

class ControlResult:
    """The optimum (or, on failure, IPOPT's last iterate) of a ControlProblem.

    status / success / iterations / wall_s (IPOPT), cost, T; t_nodes, q (full coordinates at the state nodes,
    (len, n)), support channels `channel(name)` -> (position, velocity) at the nodes, controls at t_points;
    stats (IPOPT's), kernel_time_s (estimated time in the kernels) and resimulate()."""

    def __init__(self, prob: ControlProblem, w, lam_g, status, success, stats, solve_s, warm_s, warm, attempts=()):
        self.prob, self.w, self.lam_g = prob, w, lam_g
        self.attempts = list(attempts)
        self.status, self.success, self.stats = status, bool(success), stats
        self.iterations = int(sum(a["iterations"] for a in attempts)) if attempts else int(stats.get("iter_count", 0))
        self.wall_s, self.warm_start_s, self.warm = solve_s, warm_s, warm
        self.build_s = prob.build_s + prob.solver_build_s
        Z, U, T = prob.unpack(w)
        self.Z, self.U, self.T = Z, U, T
        self.cost = float(prob.f_function(w))
        self.constraint_violation = prob.violation(w)
        self.violations = prob.violations(w)
        self.t_nodes = prob.node_times(T)
        self.t_points = prob.point_times(T)
        nf, nc = prob.nf, prob.nc
        self.q_free, self.v_free = Z[:, :nf], Z[:, nf:2 * nf]
        self.s, self.sv = Z[:, 2 * nf:2 * nf + nc], Z[:, 2 * nf + nc:]
        self.controls = U

    @property
    def q(self) -> np.ndarray:
        p = self.prob
        return (p.part.E @ self.q_free.T + p.part.c[:, None] + p.B @ self.s.T).T

    def channel(self, name: str):
        k = self.prob.channels.index(name)
        return self.s[:, k], self.sv[:, k]

    def control(self, name: str) -> np.ndarray:
        names = self.prob.channels + self.prob.force_names
        return self.U[:, names.index(name)]

    def point(self, member: str, at: Any = "end", t: np.ndarray | None = None) -> np.ndarray:
        """Position of a centreline point at the state nodes (t=None) or at times t (collocation polynomials)."""
        idx, wts = self.prob._probe(member, at)
        if t is None:
            return np.stack([self.q[:, row] @ wts for row in idx], axis=1)
        q = self.state_at(t)[0]
        return np.stack([q[:, row] @ wts for row in idx], axis=1)

    def state_at(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(full coordinates, support positions, velocities of the free coordinates) at times t from each interval's
        collocation polynomial (constant at rest after T)."""
        p = self.prob
        t = np.atleast_1d(np.asarray(t, float))
        h = self.T / p.K
        k = np.clip(np.floor(t / h).astype(int), 0, p.K - 1)
        tau = np.clip(t / h - k, 0.0, 1.0)
        base = _basis(p.tau, tau)  # (len, s+1)
        nodes = k[:, None] * (p.s + 1) + np.arange(p.s + 1)[None, :]
        Zt = np.einsum("lr,lrz->lz", base, self.Z[nodes])
        after = t >= self.T
        Zt[after] = self.Z[-1]
        nf, nc = p.nf, p.nc
        q = (p.part.E @ Zt[:, :nf].T + p.part.c[:, None] + p.B @ Zt[:, 2 * nf:2 * nf + nc].T).T
        return q, Zt[:, 2 * nf:2 * nf + nc], Zt[:, nf:2 * nf]

    def control_at(self, t) -> np.ndarray:
        """Controls at times t: each interval's Lagrange polynomial through its collocation points (zero after T)."""
        p = self.prob
        t = np.atleast_1d(np.asarray(t, float))
        h = self.T / p.K
        k = np.clip(np.floor(t / h).astype(int), 0, p.K - 1)
        tau = np.clip(t / h - k, 0.0, 1.0)
        base = _basis(p.tab.c, tau) if p.s > 1 else np.ones((len(t), 1))
        pts = k[:, None] * p.s + np.arange(p.s)[None, :]
        u = np.einsum("lj,lju->lu", base, self.U[pts])
        u[t > self.T * (1 + 1e-12)] = 0.0
        return u

    def control_in_interval(self, k: int, tau: np.ndarray) -> np.ndarray:
        """Controls of interval k at local times tau in [0, 1] (its Lagrange polynomial through the points)."""
        p = self.prob
        tau = np.atleast_1d(np.asarray(tau, float))
        base = _basis(p.tab.c, tau) if p.s > 1 else np.ones((len(tau), 1))
        return base @ self.U[k * p.s:(k + 1) * p.s]

    def support_motion(self):
        """Functions of t -> (s, s', s'') of the controlled supports consistent with the optimal accelerations:
        s'' = the control polynomials, integrated exactly from the start (a rest-hold after T)."""
        p = self.prob
        return _integrated_motion(self, p)

    def ipopt_times(self) -> dict:
        """Calls and wall time of IPOPT's function evaluations, summed over the attempts."""
        keys = ("nlp_f", "nlp_g", "nlp_grad_f", "nlp_jac_g", "nlp_hess_l")
        srcs = [a.get("calls", {}) for a in self.attempts] or [self.stats]
        return {k: {"calls": int(sum(d.get(f"n_call_{k}", 0) for d in srcs)),
                    "s": float(sum(d.get(f"t_wall_{k}", 0.0) for d in srcs))} for k in keys}

    def kernel_time(self) -> dict:
        """Estimated time in the compiled kernels during the solve: calls x measured seconds per mapped pass
        (nlp_g: gradients; nlp_jac_g: the full kernels; nlp_hess_l: the third-derivative kernels)."""
        kt = self.prob.kernel_times(self.w)
        it = self.ipopt_times()
        est = it["nlp_g"]["calls"] * kt["gradient"] + it["nlp_jac_g"]["calls"] * kt["full"] + \
            it["nlp_hess_l"]["calls"] * kt["hvp"]
        fn = sum(v["s"] for v in it.values())
        return {"kernel_s": est, "functions_s": fn, "solve_s": self.wall_s,
                "share_of_solve": est / self.wall_s if self.wall_s > 0 else float("nan"),
                "per_call": kt}

    def resimulate(self, dt: float | None = None, after: float | None = None, integrator: str = "radau",
                   **kw) -> "ResimulationReport":
        """Integrate the optimal controls with the dynamics integrator (ancf_sym.dynamics.simulate, Radau IIA by
        default, steps dividing the collocation intervals) from the start state, through T and `after` seconds of
        rest (default 3 periods of the slowest mode); compare with the collocation trajectory. See
        resimulate_motion."""
        rep = resimulate_motion(self.prob, self.T, self.support_motion(), self, dt=dt, after=after,
                                integrator=integrator, **kw)
        if rep is None:
            raise SceneError("re-simulation with the dynamics integrator needs a scene whose only position support "
                             "is the controlled one (moving frame); this scene has others")
        return rep

    def to_dict(self) -> dict:
        return {"status": self.status, "success": self.success, "iterations": self.iterations, "wall_s": self.wall_s,
                "build_s": self.build_s, "cost": self.cost, "T": self.T,
                "constraint_violation": self.constraint_violation}


def _integrated_motion(res: ControlResult, p: ControlProblem):
    """Exact integration of the piecewise polynomial accelerations (per interval) from s(0), s'(0)."""
    K, h, s = p.K, res.T / p.K, p.s
    nc = p.nc
    c = p.tab.c
    # per interval: acceleration polynomial coefficients in tau (highest first), then s', s polynomials
    polys = []
    s0, v0 = res.Z[0, 2 * p.nf:2 * p.nf + nc].copy(), res.Z[0, 2 * p.nf + nc:].copy()
    for k in range(K):
        ak = res.U[k * s:(k + 1) * s, :nc]
        entry = []
        for ch in range(nc):
            a_poly = np.polyfit(c, ak[:, ch], s - 1) if s > 1 else np.array([ak[0, ch]])
            a_t = np.poly1d(a_poly) * 1.0  # in tau; d/dt = (1/h) d/dtau
            v_t = np.polyint(a_t) * h + v0[ch]  # v(tau) = v0 + h int a dtau
            x_t = np.polyint(v_t) * h + s0[ch]
            entry.append((x_t, v_t, a_t))
        polys.append(entry)
        s0 = np.array([e[0](1.0) for e in entry])
        v0 = np.array([e[1](1.0) for e in entry])
    end = (s0, v0)

    def motion(t):
        t = np.atleast_1d(np.asarray(t, float))
        k = np.clip(np.floor(t / h).astype(int), 0, K - 1)
        tau = t / h - k
        X, V, A = (np.zeros((len(t), nc)) for _ in range(3))
        for i, (ki, ti) in enumerate(zip(k, tau)):
            if t[i] >= res.T:
                X[i], V[i] = end[0] + end[1] * (t[i] - res.T), end[1]
                continue
            for ch in range(nc):
                x_t, v_t, a_t = polys[ki][ch]
                X[i, ch], V[i, ch], A[i, ch] = x_t(ti), v_t(ti), a_t(ti)
        return X, V, A
    return motion


# -- re-simulation with the dynamics integrator ------------------------------------------------------------------

@dataclass
class ResimulationReport:
    success: bool
    status: str
    t: np.ndarray  # output times [s]
    payload: np.ndarray | None  # (len, dim) absolute position of the tracked point (first point mass or cable end)
    support: np.ndarray  # (len, nc) support displacements
    mismatch_m: float | None  # max |tracked point (simulation) - (collocation)| over [0, T] [m]
    mismatch_q: float | None  # max |free coordinates (sim) - (collocation)| at the node times [m, -]
    residual_swing_m: float | None  # max offset of the tracked point from its end equilibrium along the moved
    # axes (the payload's horizontal offset from below the trolley) over [T, T + after] [m]
    residual_motion_m: float | None  # the same as a distance (all directions) [m]
    after: float
    dt: float
    integrator: str
    wall_s: float
    q_free_at: Callable | None = None  # t -> free coordinates (absolute), by interpolation of the outputs
    v_free_at: Callable | None = None  # t -> their velocities (differences of the outputs: for warm starts)
    message: str = ""

    def to_dict(self) -> dict:
        return {"success": self.success, "status": self.status, "mismatch_m": self.mismatch_m,
                "mismatch_q": self.mismatch_q, "residual_swing_m": self.residual_swing_m,
                "residual_motion_m": self.residual_motion_m, "after": self.after,
                "dt": self.dt, "integrator": self.integrator, "wall_s": self.wall_s}


def moving_frame_ok(p: ControlProblem) -> bool:
    """The re-simulation runs the scene in the frame of the moved support: valid when it is the scene's only
    support that fixes positions (elastic energies are translation invariant, the constant loads unchanged)."""
    if not p.nc:
        return True
    supports = {(s.member, p.asm.mesh.members[s.member].node(s.at)) for s in p.scene.supports
                if s.kind in ("pin", "clamp")}
    moved = set(p._chan_support)
    return supports == moved and len(moved) == 1


def tracked_point(p: ControlProblem):
    if p.asm.point_masses:
        pm = p.asm.point_masses[0]
        return pm.member, pm.at
    return next(iter(p.scene.members)), "end"


def resimulate_motion(p: ControlProblem, T: float, motion: Callable, res: ControlResult | None,
                      dt: float | None = None, after: float | None = None, integrator: str = "radau", **dyn_kw) -> ResimulationReport | None:
    """Run ancf_sym.dynamics.simulate on the ControlAssembly in the frame of the moved support: the support's
    translation s(t) enters as the d'Alembert force -M_full Tr s''(t) (the cables' mass as 2-point Gauss point
    forces per element, exact for the cubic shape functions; the point masses as point forces), controlled forces
    as time loads. Returns None if the scene does not allow the moving frame.

    With a result `res`, the step divides the collocation interval (dt <= the given or T/400) and the load history
    holds both one-sided limits of the controls at every interval joint and at T (the optimal acceleration jumps
    there): Radau IIA's stages lie in (t, t + dt], so no step sees a joint from the wrong side. Trapezoidal-type
    schemes (Newmark, generalized-alpha) smear such a jump over one step: a swing error of order jump x dt /
    omega, which they show as a residual swing that shrinks with dt."""
    from .dynamics import DynamicOptions, TimeLoad, simulate
    if not moving_frame_ok(p):
        return None
    omega = p.modes[0]
    w1 = omega[omega > 1e-9 * max(omega.max(), 1.0)]
    period = 2 * np.pi / w1[0] if len(w1) else T
    after = 3 * period if after is None else _num("after", after, nonneg=True)
    dt_target = T / 400 if dt is None else _num("dt", dt, positive=True)
    t_end = T + after
    eps = 1e-9 * T
    if res is not None:
        h = T / p.K
        m = max(1, int(math.ceil(h / dt_target - 1e-9)))
        dt = h / m
        tau = np.linspace(0.0, 1.0, m + 1)
        th, uh = [], []
        for k in range(p.K):
            tk = (k + tau) * h
            if k:
                tk[0] += eps  # right limit at the joint; the previous interval gave the left one
            th.append(tk)
            uh.append(res.control_in_interval(k, tau))
        th.append(np.array([T + eps, max(t_end, T + 2 * eps)]))
        uh.append(np.zeros((2, p.nu)))
        th, uh = np.concatenate(th), np.concatenate(uh)
        acc = uh[:, :p.nc]
    else:
        dt = dt_target
        th = np.linspace(0.0, t_end, max(int(math.ceil(t_end / dt)) + 1, 2))
        acc = np.asarray(motion(th)[2]).reshape(len(th), p.nc)
        acc[th > T] = 0.0
        uh = np.c_[acc, np.zeros((len(th), p.nF))]
    loads = []
    dim = p.scene.dim
    if p.nc:
        for mm in p.asm.mesh.members.values():
            m = mm.member
            rhoA = m.material.density * m.section.area
            starts = np.r_[0.0, np.cumsum(mm.elem_length)[:-1]]
            for e, L in enumerate(mm.elem_length):
                for gp in (0.5 - 0.5 / math.sqrt(3), 0.5 + 0.5 / math.sqrt(3)):
                    at = float(min(starts[e] + gp * L, m.length))
                    for k, ax in enumerate(p._chan_axis):
                        F = np.zeros(dim)
                        F[ax] = -rhoA * L / 2
                        loads.append(TimeLoad(m.name, at, F, np.c_[th, acc[:, k]]))
        for pm in p.asm.point_masses:
            for k, ax in enumerate(p._chan_axis):
                F = np.zeros(dim)
                F[ax] = -pm.mass
                loads.append(TimeLoad(pm.member, pm.at, F, np.c_[th, acc[:, k]]))
    if p.nF:
        uf = uh[:, p.nc:]
        for k, c in enumerate([c for c in p.controls if isinstance(c, PointForce)]):
            d = np.asarray(c.direction, float)
            loads.append(TimeLoad(c.member, c.at, d / np.linalg.norm(d), np.c_[th, uf[:, k]]))
    # initial state in the moving frame
    s0 = p._chan_vector(p.start_values)
    if res is not None:
        q0f, v0f = res.q_free[0], res.v_free[0]
    else:
        q0f, v0f = p.q_start, np.zeros(p.nf)
    sv0 = res.Z[0, 2 * p.nf + p.nc:] if res is not None else np.zeros(p.nc)
    x0 = p.full(q0f, s0) - p.Tr @ s0
    v0 = p.part.E @ v0f + (p.B - p.Tr) @ sv0
    # outputs: node times of the collocation grid and a fine grid
    t_out = np.unique(np.r_[np.linspace(0, t_end, int(math.ceil(t_end / dt)) + 1),
                            p.node_times(T)[p.node_times(T) <= t_end]])
    sensors = []
    for name, mm in p.asm.mesh.members.items():
        for node in range(len(mm.public_nodes)):
            sensors.append({"name": f"{name}#{node}", "kind": "coordinates", "member": name, "at": node})
    mem, at = tracked_point(p)
    sensors.append({"name": "tracked", "kind": "position", "member": mem, "at": at})
    opts = DynamicOptions(dt=dt, t_end=t_end, integrator=integrator, output_times=t_out, sensors=sensors,
                          loads=loads, q0=x0, v0=v0, **dyn_kw)
    t0 = time.perf_counter()
    try:
        dyn = simulate(p.asm, opts)
    except SceneError as exc:
        return ResimulationReport(False, f"dynamics refused: {exc}", np.zeros(0), None, np.zeros((0, p.nc)), None,
                                  None, None, None, after, dt, integrator, time.perf_counter() - t0, None, None, str(exc))
    wall = time.perf_counter() - t0
    t = dyn.t
    S, _, _ = motion(t)
    S = np.asarray(S).reshape(len(t), p.nc)
    S[t > T] = np.asarray(motion(np.array([T]))[0]).reshape(1, p.nc)
    shift = (p.Tr @ S.T).T  # (len, n) translation of every coordinate
    X = np.zeros((len(t), p.n))
    for name, mm in p.asm.mesh.members.items():
        for node in range(len(mm.public_nodes)):
            X[:, mm.node_dofs(mm.node(node))] = dyn.sensors[f"{name}#{node}"]
    X += shift
    track = dyn.sensors["tracked"] + S @ np.array([np.eye(dim)[ax] for ax in p._chan_axis]).reshape(p.nc, dim) \
        if p.nc else dyn.sensors["tracked"]
    qf = X[:, p.part.roots]

    vf = np.gradient(qf, t, axis=0) if len(t) > 2 else np.zeros_like(qf)

    def q_free_at(tt):
        tt = np.atleast_1d(np.asarray(tt, float))
        return np.column_stack([np.interp(tt, t, qf[:, i]) for i in range(p.nf)])

    def v_free_at(tt):
        tt = np.atleast_1d(np.asarray(tt, float))
        return np.column_stack([np.interp(tt, t, vf[:, i]) for i in range(p.nf)])

    mismatch = mismatch_q = None
    idx, wts = p._probe(mem, at)
    if res is not None:
        during = t <= T + 1e-12
        ref = res.point(mem, at, t[during])
        mismatch = float(np.max(np.linalg.norm(track[during] - ref, axis=1)))
        tn = p.node_times(T)
        qn = q_free_at(tn)
        mismatch_q = float(np.max(np.abs(qn - res.q_free)))
    x_end = p.full(p.q_end, p._chan_vector(p.end_values))
    r_end = np.array([x_end[row] @ wts for row in idx])
    post = t >= T - 1e-12
    swing = motion_ = None
    if np.any(post):
        dev = track[post] - r_end
        axes = sorted(set(p._chan_axis)) or [0]
        swing = float(np.max(np.abs(dev[:, axes])))
        motion_ = float(np.max(np.linalg.norm(dev, axis=1)))
    return ResimulationReport(dyn.success, dyn.status, t, track, S, mismatch, mismatch_q, swing, motion_, after, dt,
                              integrator, wall, q_free_at, v_free_at, dyn.message)


__all__ = ["ControlProblem", "ControlResult", "ControlAssembly", "PointMass", "SupportMotion", "PointForce", "Effort",
           "MinimumTime", "Swing", "PathConstraint", "StateView", "ResimulationReport", "resimulate_motion"]
