"""ControlProblem: the composition of a control problem's parts (options, model, bounds, transcription, warm
start) and the IPOPT solve. Each part takes what it needs explicitly; the problem forwards their public names so
that users, results and the re-simulation read one object."""
from __future__ import annotations

import time
from typing import Any, Sequence

import casadi as ca
import numpy as np

from ancf_sym.util.interrupts import interruptible
from ancf_sym.scene.builder import Scene, SceneError
from ancf_sym.control.bounds import Bounds
from ancf_sym.control.ingredients import Effort, PathConstraint, PointMass
from ancf_sym.control.model import ControlModel, end_mode_count
from ancf_sym.control.options import check_constraints, control_options
from ancf_sym.control.result import ControlResult
from ancf_sym.control.transcription import Transcription
from ancf_sym.control.warm_start import WarmStart

SUCCESS = ("Solve_Succeeded", "Solved_To_Acceptable_Level")
FULL_STEP_ITERATIONS = 150  # cap of the full-step attempt before IPOPT's line search takes over


class ControlProblem:
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

    Its parts: options (ControlOptions), model (ControlModel), limits (Bounds), transcription (Transcription),
    warm (WarmStart); their public names are readable on the problem too (ocp.nf, ocp.K, ocp.unpack(w), ...).
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
        self.options = control_options(horizon, cost, path, terminal, intervals, stages, scheme, end_rest,
                                       end_modes, end_frequency, control_form, tol, max_iter, print_level, ipopt)
        self.model = m = ControlModel(scene, controls, point_masses)
        self.limits = Bounds(m, self.options, bounds, start, end)
        check_constraints(path, terminal, end_modes, end_frequency)
        # -- equilibria and modes ------------------------------------------------------------------------------
        s_start, s_end = m.chan_vector(self.limits.start_values), m.chan_vector(self.limits.end_values)
        self.q_start = m.equilibrium(s_start)
        self.q_end = m.equilibrium(s_end, guess=m.translated(self.q_start, s_end - s_start))
        self.modes = m.vibration_modes(self.q_end, s_end)
        # -- the NLP and its start -------------------------------------------------------------------------------
        self.transcription = Transcription(m, self.options, self.limits, self.q_start, self.q_end, self.modes)
        self.warm = WarmStart(m, self.options, self.limits, self.transcription, self.q_start)
        self._solvers, self.solver_build_s = {}, 0.0
        self.build_s = time.perf_counter() - t0

    def end_mode_count(self) -> int:
        """How many of the lowest modes about the end equilibrium the end-at-rest rows hold (see the class)."""
        o = self.options
        return end_mode_count(self.modes[0], self.model.nf, o.end_modes, o.end_frequency, o.K, o.T_bounds[1])

    # -- solve ----------------------------------------------------------------------------------------------------
    def solver(self, full_steps: bool) -> ca.Function:
        """IPOPT on the NLP with the kernels' Jacobian and Hessian. full_steps: accept every trial step (Newton on
        the KKT conditions; the filter line search crawls along the stiff cable's constraint manifold), else
        IPOPT's line search. MUMPS with AMD ordering and without its column permutation (the default choices were
3-10x slower on the crane: more fill, and more iterations at n = 8, K = 40); adaptive barrier
        parameter (the monotone one needed 200-1000 iterations on minimum-time problems with path constraints, the
        adaptive one 30-40)."""
        key = bool(full_steps)
        if key not in self._solvers:
            o = self.options
            ip = {"tol": o.tol, "max_iter": o.max_iter, "print_level": o.print_level, "sb": "yes",
                  "linear_solver": "mumps", "mumps_pivot_order": 0, "mumps_permuting_scaling": 0,
                  "mu_strategy": "adaptive"}
            if full_steps:
                ip["accept_every_trial_step"] = "yes"
                ip["max_iter"] = min(o.max_iter, FULL_STEP_ITERATIONS)
            ip.update(o.ipopt_extra)
            t0 = time.perf_counter()
            tr = self.transcription
            self._solvers[key] = ca.nlpsol("ocp", "ipopt", tr.nlp, {
                "ipopt": ip, "print_time": False, "jac_g": tr.jac_g, "hess_lag": tr.hess_lag,
                "no_nlp_grad": True, "calc_lam_p": False, "calc_lam_x": False, "calc_f": False, "calc_g": False,
                "error_on_fail": False})
            self.solver_build_s += time.perf_counter() - t0
        return self._solvers[key]

    def _run(self, w0: np.ndarray, full_steps: bool, lam_g0=None):
        S = self.solver(full_steps)
        tr = self.transcription
        args = dict(x0=w0, lbx=tr.lbx, ubx=tr.ubx, lbg=tr.lbg, ubg=tr.ubg)
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
            st, w, lam, status = {"error": str(exc)}, w0.copy(), np.zeros(self.transcription.ng), "Evaluation_Error"
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
            w0, warm = self.warm.warm_start()
        elif isinstance(guess, ControlResult):
            w0 = guess.w.copy()
        else:
            w0 = np.asarray(guess, float).ravel()
            if w0.shape != (self.transcription.nw,) or not np.all(np.isfinite(w0)):
                raise SceneError(f"guess must be {self.transcription.nw} finite numbers, got shape {np.shape(guess)}")
        warm_s = time.perf_counter() - t0
        w0 = np.clip(w0, self.transcription.lbx, self.transcription.ubx)
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
        tr = self.transcription
        g = np.asarray(tr.g_function(w)).ravel()
        v = np.maximum(tr.lbg - g, 0) + np.maximum(g - tr.ubg, 0)
        out = {}
        a, b = tr.g_rows["dynamics"]
        out["dynamics"] = float(v[a:b].max()) if b > a else 0.0
        a2, b2 = tr.g_rows["collocation"]
        out["kinematics"] = float(v[b:b2].max()) if b2 > b else 0.0
        for key in ("end", "path"):
            a, b = tr.g_rows[key]
            out[key] = float(v[a:b].max()) if b > a else 0.0
        vb = np.maximum(tr.lbx - w, 0) + np.maximum(w - tr.ubx, 0)
        out["bounds"] = float(vb.max()) if vb.size else 0.0
        return out

    def violation(self, w: np.ndarray) -> float:
        """Largest violation of the constraints (rows and variable bounds) at w, in their units (N, m, m/s)."""
        tr = self.transcription
        g = np.asarray(tr.g_function(w)).ravel()
        v = np.r_[np.maximum(tr.lbg - g, 0), np.maximum(g - tr.ubg, 0), np.maximum(tr.lbx - w, 0),
                  np.maximum(w - tr.ubx, 0)]
        return float(v.max()) if v.size else 0.0


# The parts' public names, readable on the problem (what users, the result and the re-simulation read).
FORWARDED = {
    "options": ("K", "scheme", "tab", "s", "control_form", "cost", "free_time", "T_bounds", "T_guess", "path",
                "terminal", "end_rest", "end_modes", "end_frequency", "tol", "max_iter", "print_level",
                "ipopt_extra"),
    "model": ("scene", "asm", "part", "n", "nf", "nc", "nF", "nu", "pos", "E", "B", "Tr", "controls", "channels",
              "force_names", "chan_coord", "chan_axis", "chan_support", "M_full", "Mff", "Mfc", "f_lin",
              "f_lin_full", "Bf", "nonlinear", "length_scale", "variable_names", "chan_vector", "full", "forces",
              "equilibrium", "vibration_modes", "probe", "forces_f", "force_vecs"),
    "limits": ("bounds", "start_values", "end_values"),
    "transcription": ("layout", "tau", "Pp", "nz", "Nn", "idx", "iT", "nw", "ng", "lbx", "ubx", "lbg", "ubg",
                      "g_rows", "nlp", "jac_g", "hess_lag", "g_function", "f_function", "n_end_modes", "pack",
                      "unpack", "node_times", "point_times", "stage_nodes", "kernel_times"),
    "warm": ("naive_motion", "guess_from_trajectory", "collocation_simulation", "warm_start"),
}


def _forward(part: str, name: str) -> property:
    return property(lambda self: getattr(getattr(self, part), name), doc=f"The {part}'s {name}.")


for _part, _names in FORWARDED.items():
    for _name in _names:
        setattr(ControlProblem, _name, _forward(_part, _name))
