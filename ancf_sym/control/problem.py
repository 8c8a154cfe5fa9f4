"""ControlProblem: the checks of its arguments, the build (model, bounds, NLP) and the IPOPT solve."""
from __future__ import annotations

import time
from typing import Any, Sequence

import casadi as ca
import numpy as np

from ancf_sym.util.checks import number as _num
from ancf_sym.dynamics.collocation import tableau
from ancf_sym.util.interrupts import interruptible
from ancf_sym.scene.builder import Scene, SceneError
from ancf_sym.control.bounds import BoundsMixin
from ancf_sym.control.ingredients import Effort, MinimumTime, PathConstraint, PointMass, Swing
from ancf_sym.control.model import ControlAssembly, ModelMixin
from ancf_sym.control.result import ControlResult
from ancf_sym.control.transcription import TranscriptionMixin
from ancf_sym.control.warm_start import WarmStartMixin

SUCCESS = ("Solve_Succeeded", "Solved_To_Acceptable_Level")
FULL_STEP_ITERATIONS = 150  # cap of the full-step attempt before IPOPT's line search takes over
SCHEMES = ("radau", "gauss")


class ControlProblem(ModelMixin, BoundsMixin, TranscriptionMixin, WarmStartMixin):
    """Direct collocation of a scene's dynamics with IPOPT. See the package docstring (ancf_sym.control).

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
            with interruptible():  # Ctrl-C / SIGTERM inside IPOPT stop the solve, not only this attempt
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
