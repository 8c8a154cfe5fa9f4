"""Static equilibrium: full-step Newton first, IPOPT where Newton alone is not enough. User guide: docs/statics.md.

1. Newton (statics/newton.py): full steps on the exact tangent (shifted where it is indefinite far out), the
   compiled kernels called directly (statics/evaluation.py), from the start point: the Biot-strain solution for Green and
   decoupled cables, the solution on a 10x coarser mesh for fine ones (statics/coarse.py). Measured
   (bench/STATICS_RESULTS.md) it converges in 8 (Biot) to 10 (Green, decoupled: from the Biot solution) iterations
   on a cantilever at any mesh size up to 100 000 elements, where a line search creeps along the narrow valley that
   a large EA/EI makes.
2. If Newton does not converge cleanly (diverges, stalls, exceeds its iterations), Newton again along the load
   factor in adaptive steps; if that fails too (or a result lies above the start's potential), IPOPT minimises: first accepting every trial step, then with its line search (each first with the coordinates a symmetry holds fixed, statics/held.py), then stepping the loads up; Newton
   finishes from IPOPT's point, so every answer passes the same convergence test.
   With penalty drums every Newton step is cut back before a contact point reaches a drum's axis and an IPOPT run
   with such a step is rejected (contact/steps.py); with penalty contact a converged full-load Newton is compared with
   the load-step continuation, the lower potential kept. load_stepping: load steps from the start, as asked.
3. The reduced Hessian's inertia (statics/inertia.py, one sparse factorisation) says whether the point is stable (settled
   by the banded Cholesky of the shifted tangent at the answer, which the kernel Newton's last run does, where that
   succeeds); a saddle (a straight column past its Euler load) is left along its negative-curvature direction.

Convergence is relative (tol): the Newton increment in units of the structure's length and the energy decrement in
units of the load work (statics/newton.py), not an absolute residual, whose round-off floor grows with the
element count while the nodal loads shrink.
"""
from __future__ import annotations

import functools
import time
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field

import casadi as ca
import numpy as np
import scipy.sparse as sp

from ancf_sym.bodies import planar as bodies, spatial as spatial_bodies
from ancf_sym.contact import laws as contact, gap as contact_gap
from ancf_sym.model import fields
from ancf_sym.statics import coarse as statics_coarse, contact as statics_contact
from ancf_sym.model.assembly import LOAD_LABELS, Assembly, Evaluation
from ancf_sym.util.checks import check_fields
from ancf_sym.util.interrupts import interruptible
from ancf_sym.model.mesh import check_stretch
from ancf_sym.util.names import NamedDict, lookup
from ancf_sym.scene.builder import Scene, SceneError, fingerprint
from ancf_sym.scene.schema import STATIC_OPTIONS

from ancf_sym.contact.steps import IterateWatch, deep_starts
from ancf_sym.statics.inertia import STABILITY_EPS, reduced_inertia
from ancf_sym.statics.held import held_coordinates, mirrored
from ancf_sym.scene.member_effects import START_STRAIN
from ancf_sym.statics.evaluation import BIOT, ResultEnergies
from ancf_sym.util.html import html_table
from ancf_sym.model.reduced import ReducedModel
from ancf_sym.statics.newton import KernelNewton, NewtonRun, NewtonStatics

SUCCESS = ("Solve_Succeeded", "Solved_To_Acceptable_Level")
INTERRUPTED = ("User_Requested_Stop", "User_Interrupt")
TUNNELLED = "Step_Through_Contact"  # an IPOPT step carried a contact point to a drum's axis (contact.steps)  # IPOPT swallows SIGINT and returns one of these
NEWTON_MAX_ITER = 30  # full steps before load steps take over (a cantilever needs 8-20 at any mesh size, 24 at E = 1 GPa Green)
STEP_TOL = 1e-2  # relative tolerance at intermediate load factors (a start inside the next basin is enough)
STEP_MAX_ITER = 15  # Newton iterations per load step (from a nearby converged load a few suffice)
MIN_LOAD_STEP = 1.0 / 4096  # smaller load steps than this: hand over to IPOPT
BIOT_TOL = 1e-6  # tolerance of the Biot solve that only gives the start (Newton's last steps are quadratic)
BIOT_MAX_ITER = 12  # Biot converges in 8-10 on fine meshes: give up early where it does not
BIOT_MIN_ELEMENTS = 10  # measured: on 3 and 6 elements the coupled Biot solution is no start for Green (no gain)
DECOUPLED = "decoupled"  # starts from its own rod's Biot strain at any element count (measured: 6 elements 8 + 2)
CACHE_SIZE = 8  # problems kept per process, by scene fingerprint


@dataclass
class StaticOptions:
    """tol: relative convergence tolerance (docs/statics.md): the last Newton update, positions in units of the
    structure's length and slopes as they are, and the energy decrement in units of the load work, both <= tol.
    The answer then lies within about tol^2 L of the discrete equilibrium."""
    tol: float = 1e-10
    max_iter: int = 500  # iterations per attempt (Newton runs stop at min(this, 60))
    load_steps: int = 8  # continuation steps if the direct solves fail
    escape_saddle: bool = True
    load_stepping: bool = False  # Newton along the load factor from the start (docs/statics.md, Load steps)
    print_level: int = 0

    def __post_init__(self):
        check_fields(self, STATIC_OPTIONS, "analysis")  # types and ranges as declared in ancf_sym.scene.schema
        if self.tol is None:
            self.tol = 1e-10


_DEFAULT_OPTIONS = StaticOptions()  # (read only: a solve never changes its options)


@dataclass
class StaticResult:
    """A static solve's answer. energies, constraint_forces and constraint_violation are worked out from x on first
    access (the kernels evaluated by effect, the reactions, the constraint rows): a solve pays for them only where
    they are read."""
    status: str
    success: bool
    iterations: int  # Newton + IPOPT iterations, all attempts
    wall_s: float
    x: np.ndarray
    stable: bool | None  # reduced Hessian positive definite (inertia of a sparse factorisation); None if unknown
    attempts: list = field(default_factory=list)  # what was tried, in order
    assembly: Assembly | None = None
    path: str = ""  # what solved it: "start" (nothing loads it), "newton", "ipopt+newton", "ipopt load steps+newton"
    increment: float = float("nan")  # last Newton update, relative to the structure's length
    energy_decrement: float = float("nan")  # last -r.dz, relative to the load work
    residual: float = float("nan")  # max |residual| at the last evaluated point [N]
    residual_floor: float = float("nan")  # its round-off level, eps x max |K| x span [N]
    # IPOPT's multipliers of every row of a statics with exact contact (statics.contact: a finer mesh's warm start)
    contact_multipliers: np.ndarray | None = field(default=None, repr=False, compare=False)
    _work_out: Callable[[], tuple] | None = field(default=None, repr=False, compare=False)  # () -> the three below

    @functools.cached_property
    def _details(self) -> tuple:
        return self._work_out()

    @functools.cached_property
    def energies(self) -> dict:
        """label -> energy at x [J]: strain energies by effect, gravity, loads, penalty springs."""
        return NamedDict(self._details[0], kind="energy label")

    @functools.cached_property
    def constraint_forces(self) -> dict:
        """label -> multipliers (exact constraints) or penalty forces."""
        return NamedDict(self._details[1], kind="constraint label")

    @functools.cached_property
    def constraint_violation(self) -> float:
        return self._details[2]

    @property
    def potential(self) -> float:
        return float(sum(self.energies.values()))

    @property
    def strain_energy(self) -> float:
        return float(sum(v for k, v in self.energies.items() if k not in ("gravity", "loads", "penalty")))

    @property
    def solved_by(self) -> str:
        """Which solver produced x, in its own words: e.g. "Newton (converged, 2 iterations; from a Biot-strain
        start, 7 iterations)" or "IPOPT line search (Solve_Succeeded, 31 iterations), then Newton (converged, 1
        iteration)". `status` keeps one vocabulary for every path (IPOPT's return codes); this says who answered."""
        if not self.success:
            last = self.attempts[-1] if self.attempts else {}
            return f"no solver succeeded (last: {_attempt_text(last)})" if last else "no solver succeeded"
        done = [a for a in self.attempts if _attempt_produced(a)]
        return ", then ".join(_attempt_text(a) for a in done) or self.path or "?"

    def summary(self) -> str:
        """One line: status, who solved it, the key numbers."""
        text = f"statics {'succeeded' if self.success else 'FAILED: ' + self.status}: {self.solved_by}, {self.wall_s:.3g} s"
        if self.success and self.assembly is not None:
            text += f"; potential {self.potential:.6g} J"
            if self.stable is not None:
                text += ", stable" if self.stable else ", UNSTABLE equilibrium"
        return text

    def __repr__(self) -> str:
        members = list(self.assembly.mesh.members) if self.assembly is not None else []
        tips = "; ".join(f"tip({m!r}) = {np.array2string(self.tip(m), precision=5)} m" for m in members[:3])
        more = f" (+{len(members) - 3} members)" if len(members) > 3 else ""
        return f"<StaticResult {self.summary()}" + (f"; {tips}{more}" if tips else "") + ">"

    def _repr_html_(self) -> str:
        return html_table("StaticResult", self.summary(), [
            ("status", self.status), ("solved by", self.solved_by), ("iterations", self.iterations),
            ("wall time", f"{self.wall_s:.3g} s"),
            ("potential", f"{self.potential:.6g} J" if self.success and self.assembly is not None else "-"),
            ("stable", self.stable), ("coordinates", self.x.size)]
            + [(f"tip('{m}')", f"{np.array2string(self.tip(m), precision=5)} m")
               for m in (list(self.assembly.mesh.members)[:5] if self.assembly is not None else [])])

    def _member(self, member: str):
        """The mesh of a member by name; a wrong name is refused listing the members there are."""
        return lookup("member", member, self.assembly.mesh.members)

    def nodes(self, member: str) -> np.ndarray:
        """Node positions (public nodes) [m]."""
        mm = self._member(member)
        xn = self.assembly.member_coordinates(self.x, member)
        return xn[mm.public_nodes, :self.assembly.scene.dim]

    def slopes(self, member: str) -> np.ndarray:
        mm = self._member(member)
        d = self.assembly.scene.dim
        return self.assembly.member_coordinates(self.x, member)[mm.public_nodes, d:2 * d]

    def tip(self, member: str) -> np.ndarray:
        return self.nodes(member)[-1]

    def body(self, name: str) -> tuple:
        """Planar: (x, y, angle) of a rigid body's centre of mass [m, m, rad]. Spatial: (centre [m], axes), the
        axes' rows its x, y, z axes in world components."""
        if self.assembly.scene.dim == 3:
            return spatial_bodies.state(self.x, lookup("body", name, self.assembly.mesh.bodies))
        return bodies.state(self.x, lookup("body", name, self.assembly.mesh.bodies))

    def _body_record(self, name: str) -> dict:
        if self.assembly.scene.dim == 3:
            r, E = self.body(name)
            return {"position": r.tolist(), "axes": E.tolist()}
        return dict(zip(("x", "y", "angle"), self.body(name)))

    def along(self, member: str, per_element: int = 8) -> dict:
        """s, r, stretch |r_x|-1 ("strain"), the member's own axial strain measure ("axial_strain",
        fields.axial_measure) and curvature along the member (ancf_sym.model.fields.sample)."""
        mm = self._member(member)
        return fields.sample(mm, self.assembly.member_coordinates(self.x, member), per_element)

    def to_dict(self) -> dict:
        return {
            "status": self.status, "success": self.success, "iterations": self.iterations, "wall_s": self.wall_s,
            "energies": self.energies, "potential": self.potential if self.success else None,
            "constraint_violation": self.constraint_violation, "stable": self.stable, "attempts": self.attempts,
            "path": self.path, "increment": self.increment, "energy_decrement": self.energy_decrement,
            "residual": self.residual, "residual_floor": self.residual_floor,
            "members": {name: {"nodes": self.nodes(name).tolist(), "slopes": self.slopes(name).tolist()}
                        for name in self.assembly.mesh.members},
            "bodies": {name: self._body_record(name) for name in self.assembly.mesh.bodies},
            "constraint_forces": {k: np.asarray(v).tolist() for k, v in self.constraint_forces.items()},
        }


def _attempt_produced(a: dict) -> bool:
    """An attempt whose answer was kept: Newton converged, or IPOPT succeeded and was not rejected."""
    return a.get("method") != "none" and not a.get("rejected") and a.get("status") in ("converged",) + SUCCESS \
        or (a.get("method") == "none" and a.get("status") in SUCCESS)


def _attempt_text(a: dict) -> str:
    m = a.get("method", "?")
    if m == "none":
        return a.get("detail") or f"no solve ({a.get('status')})"
    name = ("IPOPT" + m[len("ipopt"):]) if m.startswith("ipopt") else ("Newton" + m[len("newton"):]) \
        if m.startswith("newton") else m
    it = a.get("iterations", 0)
    text = f"{name} ({a.get('status')}, {it} iteration{'' if it == 1 else 's'}"
    for key, what in (("biot_start", "a Biot-strain start"), ("coarse_start", "a coarser mesh's solution")):
        st = a.get(key)
        if st and st.get("used"):
            text += f"; from {what}, {st.get('iterations', 0)} iterations"
    return text + ")"


class StaticProblem:
    """A scene's static problem, built once: the Newton iteration's index maps now (the StepSystem graph only for
    scenes with multiplier rows), IPOPT's problem on first need (load factor as a parameter); solved as often as
    needed."""

    def __init__(self, scene_or_assembly: Scene | Assembly, progress: Callable[[str], None] | None = None):
        """progress: called with a line of text before and after each IPOPT attempt (the command line's bar)."""
        self.asm = scene_or_assembly if isinstance(scene_or_assembly, Assembly) else Assembly(scene_or_assembly)
        self.progress = progress
        self.S = ReducedModel(self.asm)  # free coordinates (the graph's StepSystem has the same)
        self.light = KernelNewton(self.asm, self.S) if self.S.mc == 0 else None
        self._graph: NewtonStatics | None = None
        self.newton = self.light or self.graph
        self.solves = 0
        self.nlp = None  # IPOPT's problem, built on first use (build_nlp)
        self.contact_nlp = None  # exact contact's IPOPT problem (statics.contact, on first use)
        self.contact_coarse = None  # exact contact's coarser problem: None not yet asked, False none
        self._solvers: dict = {}
        self._watch: IterateWatch | None = None  # IPOPT's steps checked against the contact step limit
        self._biot: KernelNewton | bool | None = None  # Newton on the same scene with Biot strain (a start)
        self._coarse: StaticProblem | bool | None = None  # the scene meshed coarser (a start on fine meshes)
        self._result_energies: ResultEnergies | None = None  # energies by label for results (kernel path)
        self.work = self.newton.load_work(self.asm.x0)  # the loads' energy scale W [J]
        a = self.asm
        self._loaded = bool(np.any(self.S.f_lin) or np.any(a.Q) or any(mk.term.label in LOAD_LABELS for mk in a.mapped))
        self._contacts = bool(contact.exact_contacts(a))
        self._penalty_contact = any(c.method == "penalty" for c in getattr(a.scene, "contacts", ()))
        self._gaps = bool(contact_gap.checked_contacts(a.scene))  # contact held at points: check between them

    @property
    def graph(self) -> NewtonStatics:
        """The compiled Newton iteration (built on first use)."""
        if self._graph is None:
            self._graph = NewtonStatics(self.asm)
        return self._graph

    def _engine(self) -> NewtonStatics:
        """Which evaluation runs the Newton iterations (measured, bench/STATICS_RESULTS.md): the kernels called
        directly (KernelNewton, its loop in C where the evaluation is plain) cost ~47 us per iteration at 60
        elements and ~5.5 ms at 6000, with nothing to build; the compiled StepSystem graph ~50 us / ~13 ms after
        ~35 ms / ~1 s of building. Only scenes with multiplier rows (rigid joints, skew clamps) need the graph's KKT
        solve."""
        return self.light if self.light is not None else self.graph

    # -- IPOPT --------------------------------------------------------------------------------------------------
    def build_nlp(self) -> None:
        a = self.asm
        x, lam = ca.MX.sym("x", a.n), ca.MX.sym("load_factor")
        f, grad, hess, g = a.casadi_parts(x, lam)
        lam_f, lam_g = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", g.shape[0])
        hl = lam_f * hess
        if g.shape[0] and len(a.exact.qrow):
            hl += ca.triu(ca.hessian(ca.dot(lam_g, g), x)[0])
        self.nlp = {"x": x, "p": lam, "f": f, "g": g}
        self.grad_f = ca.Function("nlp_grad_f", [x, lam], [f, grad], ["x", "p"], ["f", "grad_f_x"])
        self.hess_lag = ca.Function("nlp_hess_l", [x, lam, lam_f, lam_g], [hl],
                                    ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"])
        ev = a.evaluate(a.x0)  # penalty springs included: their round-off is as real as the kernels'
        kmax = float(abs(ev.hessian).max()) if ev.hessian.nnz else 1.0
        self.floor = float(np.finfo(float).eps * kmax * (float(np.max(np.abs(a.x0))) + 1.0))

    def solver(self, line_search: bool, opts: StaticOptions):
        """IPOPT, tolerance at twice the gradient's round-off floor (absolute): it only has to bring the point into
        Newton's reach; the Newton finish then applies the relative test."""
        if self.nlp is None:
            self.build_nlp()
        key = (line_search, opts.max_iter, opts.print_level)
        if key not in self._solvers:
            tol = max(2.0 * self.floor, 1e-14)
            ipopt = {"tol": tol, "dual_inf_tol": tol, "acceptable_tol": 10 * tol, "acceptable_dual_inf_tol": 10 * tol,
                     "acceptable_iter": 3, "max_iter": int(opts.max_iter), "constr_viol_tol": 1e-10,
                     "nlp_scaling_method": "none", "print_level": opts.print_level, "sb": "yes"}
            if not line_search:
                ipopt["accept_every_trial_step"] = "yes"
            watch = {}
            if self.newton.step_limit is not None:  # penalty drums: every IPOPT step checked for a crossing
                if self._watch is None:
                    self._watch = IterateWatch(self.newton.step_limit, self.asm.n, self.nlp["g"].shape[0], 1)
                watch = {"iteration_callback": self._watch}
            self._solvers[key] = ca.nlpsol("statics", "ipopt", self.nlp, {
                "ipopt": ipopt, "print_time": False, "grad_f": self.grad_f, "hess_lag": self.hess_lag,
                "error_on_fail": False, **watch})
        return self._solvers[key]

    def _run(self, x0, lam_g0, load, line_search, opts, held=None):
        what = ("line search" if line_search else "full steps") + ("" if load == 1.0 else f", load {load:.3g}") + \
            ("" if held is None else ", symmetric coordinates held")
        if self.progress is not None:
            self.progress(f"IPOPT {what} ...")
        ok, status, it, x, lam = self._ipopt_run(x0, lam_g0, load, line_search, opts, held)
        if self.progress is not None:
            self.progress(f"IPOPT {what}: {status}, {it} it")
        return ok, status, it, x, lam

    def _ipopt_run(self, x0, lam_g0, load, line_search, opts, held=None):
        m = self.asm.exact.m
        args = {"x0": x0, "p": load, "lbg": np.zeros(m), "ubg": np.zeros(m)}
        if held is not None and held.size:  # coordinates a symmetry holds (statics.held): fixed at x0's values
            lbx, ubx = np.full(self.asm.n, -np.inf), np.full(self.asm.n, np.inf)
            lbx[held] = ubx[held] = x0[held]
            args["lbx"], args["ubx"] = lbx, ubx
        if lam_g0 is not None:
            args["lam_g0"] = lam_g0
        # Ctrl-C / SIGTERM inside IPOPT: raised here, not tried again as a failed attempt. Building the solver is
        # inside too: CasADi checks for signals while it builds and swallows the exception there as well.
        with interruptible() as rec:
            S = self.solver(line_search, opts)
            if self._watch is not None:
                self._watch.reset(x0)
            if rec.exc is None:  # a signal swallowed while building: raised on leaving the block, no solve first
                sol = S(**args)
        st = S.stats()
        if st["return_status"] in INTERRUPTED:  # Ctrl-C during IPOPT: stop, never try the next attempt
            raise KeyboardInterrupt
        x = np.asarray(sol["x"]).ravel()
        ok = st["return_status"] in SUCCESS and np.all(np.isfinite(x))
        status = st["return_status"]
        if self._watch is not None and self._watch.crossed:  # its answer may lie past a drum: not an answer
            ok, status = False, TUNNELLED
        return ok, status, int(st["iter_count"]), x, np.asarray(sol["lam_g"]).ravel()

    def _ipopt(self, x, opts, attempts, ceiling):
        """IPOPT's attempts: full steps, line search (first with the coordinates a symmetry holds fixed, where there
        are such: statics.held), load steps. (ok, x, lam_g, path)."""
        held = self._held(x)
        best = None  # (penalty contact: a full-step answer, kept unless the line search's lies lower)
        for hold, line_search in ([(True, False), (True, True)] if held.size else []) + [(False, False), (False, True)]:
            if best is not None and not (line_search and hold == best[0]):
                break
            ok, status, it, xs, lg = self._run(x, None, 1.0, line_search, opts, held if hold else None)
            attempts.append({"method": "ipopt " + ("line search" if line_search else "full steps") +
                             (", symmetric coordinates held" if hold else ""), "status": status, "iterations": it})
            if ok and self.asm.energy(xs) > ceiling:  # full steps can jump into another basin and converge there
                ok = False
                attempts[-1]["rejected"] = "potential above that of the feasible start point"
            if ok and hold and not self._still_held(xs, held):
                ok = False
                attempts[-1]["rejected"] = "the held coordinates are loaded at its answer (no symmetry holds them)"
            if ok and self._gaps and contact_gap.hidden(self.asm, xs)[1]:  # (full steps can land on a folded line
                ok = False  # whose centre line dips through the ground between the law's points: try the next)
                attempts[-1]["rejected"] = "its centre line passes through a contact surface between the law's points"
            if ok and best is not None:  # (the full steps' answer and the line search's: the lower potential)
                if self.asm.energy(xs) < self.asm.energy(best[1]) - opts.tol * self.work:
                    attempts[-1]["chosen"] = "potential below the full steps' answer"
                    return True, xs, lg, "ipopt+newton"
                return True, best[1], best[2], "ipopt+newton"
            if ok and not line_search and self._penalty_contact:  # with penalty contact full steps can land on a
                best = (hold, xs, lg)  # higher local minimum (a slack line folded on the seabed): the line search too
                continue
            if ok:
                return True, xs, lg, "ipopt+newton"
        if best is not None:  # (the line search failed: the full steps' answer)
            return True, best[1], best[2], "ipopt+newton"
        xk, lgk = x, None  # continuation from the last converged load level
        for k in range(1, opts.load_steps + 1):
            okk, status, it, xs, lg = self._run(xk, lgk, k / opts.load_steps, True, opts)
            attempts.append({"method": f"ipopt load step {k}/{opts.load_steps}", "status": status, "iterations": it})
            if not okk:
                return False, x, None, "ipopt load steps"
            xk, lgk = xs, lg
        return True, xk, lgk, "ipopt load steps+newton"

    def _held(self, x: np.ndarray) -> np.ndarray:
        """Coordinates that nothing loads or couples at x (statics.held: a symmetry keeps them there), at the
        round-off levels of the gradient (the problem's floor) and of the Hessian (eps x max |K|)."""
        a = self.asm
        if self.nlp is None:
            self.build_nlp()
        ev = a.evaluate(x)
        kmax = float(abs(ev.hessian).max()) if ev.hessian is not None and ev.hessian.nnz else 0.0
        rows = a.exact.jacobian(x) if a.exact.m else None
        held = held_coordinates(ev.gradient, ev.hessian, rows, self.floor, np.finfo(float).eps * kmax)
        if held.size and not mirrored(lambda y: a.evaluate(y, hessian=False).gradient, x, held, rows):
            return np.zeros(0, dtype=np.int64)  # (decoupled at the start only: no symmetry holds them)
        return held

    def _still_held(self, x: np.ndarray, held: np.ndarray) -> bool:
        """Nothing loads the held coordinates at x either (their gradient within the round-off floor, as at the
        start): a symmetry held them along the way, and x is an equilibrium in them too. A decoupling of the start's
        tangent alone (a straight beam's transverse and axial coordinates) does not pass."""
        g = self.asm.evaluate(x, hessian=False).gradient
        return bool(np.max(np.abs(g[held])) <= self.floor)

    # -- the solve ----------------------------------------------------------------------------------------------
    def coarser(self, scene: Scene) -> "StaticProblem":
        """The problem of a coarser mesh of this scene, a start for this one (statics.contact builds it through
        this, so that it needs no import of this module)."""
        return StaticProblem(scene)

    def solve(self, opts: StaticOptions | None = None, x0: np.ndarray | None = None) -> StaticResult:
        opts = opts or _DEFAULT_OPTIONS
        a = self.asm
        if getattr(a.scene, "water", None) is not None and not getattr(a.scene, "water_start", False):
            from ancf_sym.statics.water import solve_in_water  # (Newton on the residual: drag, water line, fairleads)

            return solve_in_water(a.scene, opts, x0, solve_static=solve_static, result_type=StaticResult)
        if getattr(a.scene, "drives", None):  # dry: a drive is the dynamics' prescribed motion, which the statics'
            a.scene.validate_for_statics()  # rows leave out: refused (as solve_static does) rather than ignored
        t0 = time.perf_counter()
        self.solves += 1
        self.newton = self._engine()
        if x0 is None:
            x = a.x0.copy()
        else:
            x = np.asarray(x0, float).copy()
            if x.shape != (a.n,) or not np.all(np.isfinite(x)):
                raise SceneError(f"warm start x0 must be {a.n} finite numbers, got shape {np.shape(x0)}")
            check_stretch(a.mesh, x, "warm start x0")
            x = self.S.full(self.S.reduce(x))  # supports and hinges that fix or identify coordinates hold exactly
        if self._contacts:  # exact frictionless contact: IPOPT with inequality rows
            return statics_contact.solve(self, x, opts, t0, x0 is not None)
        attempts: list = []
        work = self.work if self.work > 0 else self.newton.load_work(x)
        if work == 0.0 or self._unloaded_at_rest(x):  # the start is the equilibrium
            attempts.append({"method": "none", "status": "Solve_Succeeded", "iterations": 0,
                             "detail": "no load and no residual force at the start: solved at the start shape"})
            stable, _ = self.stability(x)
            return self.make_result(True, "Solve_Succeeded", 0, time.perf_counter() - t0, x, stable, attempts, "start",
                                None)
        ceiling = self._start_ceiling(x, work, opts.tol, x0 is None)
        n_iter = min(NEWTON_MAX_ITER, int(opts.max_iter))
        if opts.load_stepping:  # the loads in steps from the start, as asked
            run, ok = self._newton_load_steps(x, opts, work, ceiling, attempts, first=1.0 / opts.load_steps,
                                              cap=1.0 / opts.load_steps)
            return self._after_newton(run, ok, attempts[-1]["iterations"], "newton load steps", x, opts, work,
                                      ceiling, attempts, t0)
        coarse = self._coarse_start(opts) if x0 is None and self._coarse is not False else None
        run, used, iters, biot = None, False, 0, None
        if coarse is not None and coarse[0].success:  # Newton from the coarse mesh's solution
            run = self.newton.solve(coarse[1], opts.tol, n_iter, work, finish=STABILITY_EPS)
            used, iters = run.converged, (0 if run.converged else run.iterations)  # a discarded run's count
        coarse_used = used
        if not used:
            biot = self._biot_start(x, opts, work) if x0 is None else None
            if biot is not None and biot.converged:  # Newton from the Biot solution
                run = self.newton.solve(biot.x, opts.tol, n_iter, work, finish=STABILITY_EPS)
                used, iters = run.converged, iters + (0 if run.converged else run.iterations)
        if not used:
            run = self.newton.solve(x, opts.tol, n_iter, work, finish=STABILITY_EPS)
        attempts.append(self._newton_attempt("newton", run))
        if coarse is not None:
            members = self._coarse.asm.scene.members
            attempts[-1]["coarse_start"] = {"elements": {k: m.elements for k, m in members.items()},
                                            "status": coarse[0].status, "iterations": coarse[0].iterations,
                                            "used": coarse_used}
            iters += coarse[0].iterations
        if biot is not None:
            attempts[-1]["biot_start"] = {"status": biot.status, "iterations": biot.iterations,
                                          "used": used}
        iters += run.iterations + (biot.iterations if biot is not None else 0)
        path = "newton"
        ok = run.converged and self._potential(run) <= ceiling
        if run.converged and not ok:
            attempts[-1]["rejected"] = "potential above that of the feasible start point"
        if not ok and run.status in ("diverged", "stalled", "max_iter", "not_finite"):
            run, ok = self._newton_load_steps(x, opts, work, ceiling, attempts)
            iters += attempts[-1]["iterations"]
            path = "newton load steps"
        elif ok and self._penalty_contact and x0 is None:  # which contact state a solve reaches depends on its path: the
            steps, ok_steps = self._newton_load_steps(x, opts, work, ceiling, attempts)  # continuation's, if lower
            iters += attempts[-1]["iterations"]
            if ok_steps and self._potential(steps) < self._potential(run) - opts.tol * work:
                attempts[-1]["chosen"] = (f"potential {self._potential(steps):.6g} J below the direct Newton's "
                                          f"{self._potential(run):.6g} J")
                run, path = steps, "newton load steps"
        return self._after_newton(run, ok, iters, path, x, opts, work, ceiling, attempts, t0)

    def _after_newton(self, run, ok, iters, path, x, opts, work, ceiling, attempts, t0) -> StaticResult:
        """IPOPT where Newton did not converge, then the stability of the answer (escape_saddle)."""
        if not ok and run.status != "round_off":
            if self._unresolvable(attempts):
                return self.make_result(False, "Round_Off_Floor_Above_Loads", iters, time.perf_counter() - t0, x, None,
                                    attempts, "", None)
            n_before = len(attempts)
            ok, xs, lg, path = self._ipopt(x, opts, attempts, ceiling)
            iters += sum(at["iterations"] for at in attempts[n_before:])
            if ok:
                run = self._finish(xs, lg, opts, work, attempts)
                iters += run.iterations
                ok = run.converged
        status = "Solve_Succeeded" if ok else self._failure(run, attempts, opts, x)
        x_out = run.x if ok else x
        stable = None
        if ok:  # (the kernel Newton's finish tested the answer's tangent: a positive definite one settles it)
            stable, direction = (True, None) if run.stable else self.stability(x_out)
            if stable is False and opts.escape_saddle:
                x_out, status, stable, it = self._leave_saddle(x_out, direction, status, opts, work, attempts)
                iters += it
                if stable is False:  # a saddle no nudge left: an equilibrium, not the minimum asked for
                    ok, status = False, "Unstable_Stationary_Point"
                    attempts.append({"method": "stability", "status": status, "iterations": 0,
                                     "detail": "the equilibrium found is unstable (a saddle of the potential) and no "
                                               "stable point of lower potential was found from it; its coordinates "
                                               "are the result's x (escape_saddle=False accepts an unstable one)"})
        return self.make_result(ok, status, iters, time.perf_counter() - t0, x_out, stable, attempts, path,
                            run if ok else None)

    def _coarse_start(self, opts: StaticOptions) -> tuple[StaticResult, np.ndarray] | None:
        """The scene meshed coarser (statics.coarse), solved with the same options, and its solution interpolated
        onto this mesh: (coarse result, fine coordinates), None where there is no coarse start. The coarse problem
        is built once and kept (it may start from a coarser mesh itself)."""
        if self._coarse is None:
            c = statics_coarse.coarse_scene(self.asm.scene)
            self._coarse = self.coarser(c) if c is not None else False
        if self._coarse is False:
            return None
        rc = self._coarse.solve(opts)
        if not rc.success:
            return rc, None
        xf = statics_coarse.interpolate(self._coarse.asm, rc.x, self.asm)
        return rc, self.S.full(self.S.reduce(xf))  # supports and hinges that fix or identify coordinates exactly

    def _biot_start(self, x, opts, work) -> NewtonRun | None:
        """The Biot-strain solution of the same scene (a start for cables with Green or decoupled strain, to
        BIOT_TOL); None without such cables or on a coarse mesh. Measured (bench/STATICS_RESULTS.md): Biot Newton
        converges in 8-10 iterations on paper 000's cantilever where Green needs 19-24 from the straight beam, and
        Green then needs 2-3 more from Biot's answer (the strain measures differ by O(strain^2)). The Biot Newton
        shares this problem's index maps (ReducedEvaluation.variant): only its kernel calls differ. Scenes with
        multiplier rows (the graph) start from the straight state."""
        if self._biot is None:
            cables = [m for m in self.asm.scene.members.values() if m.axial not in (None, START_STRAIN)]
            coarse = any(m.elements < BIOT_MIN_ELEMENTS for m in cables if m.axial != DECOUPLED)
            ev = self.light.ev.variant(BIOT) if cables and not coarse and self.light is not None else None
            self._biot = KernelNewton(self.asm, self.S, ev) if ev is not None else False
        if self._biot is False:
            return None
        return self._biot.solve(x, max(opts.tol, BIOT_TOL), min(BIOT_MAX_ITER, int(opts.max_iter)), work)

    def _newton_load_steps(self, x, opts, work, ceiling, attempts, first: float = 0.5, cap: float = 1.0):
        """Full-step Newton along the load factor with an adaptive step (as Exudyn's static solver adapts its load
        steps): a converged step doubles the next one, a failed one is retried at a quarter. Intermediate loads only
        need a point inside the next one's basin (tol STEP_TOL); a Newton iteration costs ~50 us at 60 elements,
        so even a hundred of them undercut one IPOPT run. (run, evaluation, ok)."""
        done, step, run, n_runs, its = 0.0, first, None, 0, 0
        while done < 1.0:
            target = min(1.0, done + step)
            final = target >= 1.0
            run = self.newton.solve(x, opts.tol if final else max(opts.tol, STEP_TOL),
                                    min(STEP_MAX_ITER, int(opts.max_iter)), work, load=target,
                                    finish=STABILITY_EPS if final else 0.0)
            n_runs += 1
            its += run.iterations
            if run.converged:
                x, done, step = run.x, target, min(2.0 * step, cap)
            else:
                step *= 0.25
                if step < MIN_LOAD_STEP:
                    break
        attempts.append({"method": "newton load steps", "status": run.status if done < 1.0 else "converged",
                         "iterations": its, "runs": n_runs, "load_reached": done,
                         "increment": run.increment, "energy_decrement": run.energy_decrement})
        if done < 1.0:
            return run, False
        if self._potential(run) > ceiling:
            attempts[-1]["rejected"] = "potential above that of the feasible start point"
            return run, False
        return run, True

    def _potential(self, run: NewtonRun) -> float:
        """Total potential at a converged run's answer (the kernel Newton's finish computed it, else here)."""
        if run.potential == run.potential:  # (not NaN)
            return run.potential
        return self.light.potential(run.x) if self.light is not None else self.asm.energy(run.x)

    def _evaluation(self, x: np.ndarray) -> Evaluation:
        """Potential, energies by label and full gradient at x (no Hessian): a result's details. Kernel path: from
        the energy-only kernels and the ReducedEvaluation (statics.evaluation.ResultEnergies); else the Assembly's
        evaluation."""
        if self.light is None:
            return self.asm.evaluate(x, hessian=False)
        if self._result_energies is None:
            self._result_energies = ResultEnergies(self.asm)
        re, ev = self._result_energies, self.light.ev
        ev.evaluate(x)
        energies = re.energies(x)
        return Evaluation(float(sum(energies.values())), energies, re.gradient(ev, x), None)

    def unloaded_at_rest(self, x: np.ndarray) -> bool:
        """Is x an equilibrium because nothing loads the scene and nothing is strained there? (See below.)"""
        return self._unloaded_at_rest(x)

    def _unloaded_at_rest(self, x: np.ndarray) -> bool:
        """No load term (gravity, forces, moments) in the scene and the start's residual at its round-off level
        (eps x max|K| x span): nothing loads it and nothing is strained."""
        a = self.asm
        if self._loaded:
            return False
        ev = a.evaluate(x)
        r = self.S.reduce_force(ev.gradient)
        kmax = float(abs(ev.hessian).max()) if ev.hessian.nnz else 0.0
        return float(np.max(np.abs(r), initial=0.0)) <= 100 * np.finfo(float).eps * kmax * self.S.span

    def _unresolvable(self, attempts: list) -> bool:
        """Newton failed and IPOPT's absolute tolerance (twice the gradient's round-off floor, which it cannot go
        below) lies above a tenth of the largest start residual: IPOPT would stop at once (or wander) and call the
        start an equilibrium. Refuse, with the reason."""
        if self.nlp is None:
            self.build_nlp()
        start = self.S.reduce_force(self.asm.evaluate(self.asm.x0, hessian=False).gradient)
        load = float(np.max(np.abs(start))) if start.size else 0.0
        if not self.floor > 0.1 * load:
            return False
        attempts.append({"method": "none", "status": "Round_Off_Floor_Above_Loads", "iterations": 0,
                         "detail": f"Newton did not converge and the gradient's round-off floor {self.floor:.3g} N "
                                   f"exceeds a tenth of the largest applied force {load:.3g} N: IPOPT cannot resolve "
                                   "these loads (stiffness or penalty factor too large for double precision)"})
        return True

    def _newton_attempt(self, method: str, run: NewtonRun) -> dict:
        return {"method": method, "status": run.status, "iterations": run.iterations,
                "increment": run.increment, "energy_decrement": run.energy_decrement}

    def _finish(self, x, lam_g, opts, work, attempts) -> NewtonRun:
        """Newton from IPOPT's point (with its multipliers of the rows Newton keeps) to the relative test."""
        lam = np.asarray(lam_g)[self.S.part.rows] if lam_g is not None and self.S.mc else None
        run = self.newton.solve(x, opts.tol, min(NEWTON_MAX_ITER, int(opts.max_iter)), work, lam=lam,
                                finish=STABILITY_EPS)
        attempts.append(self._newton_attempt("newton finish", run))
        return run

    def _failure(self, run: NewtonRun, attempts: list, opts: StaticOptions, start: np.ndarray | None = None) -> str:
        """Status of a failed solve; Newton's updates stalled above tol mean round-off, not a lack of effort."""
        if run.status == "round_off":
            attempts.append({"method": "none", "status": "Round_Off_Floor_Above_Loads", "iterations": 0,
                             "detail": f"Newton's updates stopped contracting at {run.increment:.3g} L (tol "
                                       f"{opts.tol:g}): the solution's round-off floor lies above the tolerance; the "
                                       f"residual {run.residual:.3g} N against its round-off level "
                                       f"{run.residual_floor:.3g} N: stiffness (or penalty factor) too large for "
                                       "double precision at these loads"})
            return "Round_Off_Floor_Above_Loads"
        last = attempts[-1]["status"]
        if last == TUNNELLED:
            deep = deep_starts(self.newton.step_limit, self.asm.x0 if start is None else start)
            attempts.append({"method": "none", "status": TUNNELLED, "iterations": 0,
                             "detail": "Newton did not converge and IPOPT's steps carried a contact point to a drum's "
                                       "axis (an answer past the drum is no answer)" +
                                       (": the start cuts through a drum: " + "; ".join(deep) if deep else "") +
                                       ". Try load_stepping, a warm start outside the drums or a Hertz law"})
        return last if last not in ("converged", "max_iter", "diverged", "not_finite", "stalled") else "Unresolved_Residual"

    def _leave_saddle(self, x, direction, status, opts, work, attempts):
        """Restart from x nudged along the negative-curvature direction (IPOPT full steps, then line search, then
        the Newton finish); keep the first converged point of lower potential. (x, status, stable, iterations)."""
        a = self.asm
        e0 = a.energy(x)
        iters = 0
        if direction is None:
            return x, status, False, 0
        for scale in (1e-3, 1e-2, 1e-1):
            xp = x + scale * self._length_scale() * direction
            for line_search in (False, True):
                ok, st, it, xs, lg = self._run(xp, None, 1.0, line_search, opts)
                iters += it
                attempts.append({"method": f"leave saddle ({scale:g} L, {'line search' if line_search else 'full steps'})",
                                 "status": st, "iterations": it})
                if ok and a.energy(xs) < e0 - 1e-12 * abs(e0):
                    run = self._finish(xs, lg, opts, work, attempts)
                    iters += run.iterations
                    if run.converged and a.energy(run.x) < e0 - 1e-12 * abs(e0):
                        stable, _ = self.stability(run.x)
                        return run.x, st if st == "Solve_Succeeded" else "Solve_Succeeded", stable, iters
        return x, status, False, iters

    def _start_ceiling(self, x: np.ndarray, work: float, tol: float, reference: bool = False) -> float:
        """Highest potential an accepted solution may have: that of the start point, if it satisfies the exact
        constraints (a minimiser started there cannot rightly end higher), plus tol x the load work; +inf for an
        infeasible start. reference: x is the scene's reference state (else compared)."""
        a = self.asm
        reference = reference or np.array_equal(x, a.x0)
        if reference and hasattr(self, "_e_ref"):
            return self._e_ref + tol * work
        if a.exact.m and np.max(np.abs(a.exact.value(x))) > 1e-9 * self._length_scale():
            e = np.inf
        else:
            e = self.light.potential(x) if self.light is not None else a.energy(x)
        if reference:
            self._e_ref = e
        return e + tol * work

    def _length_scale(self) -> float:
        return self.asm.mesh.length_scale

    def multipliers(self, x: np.ndarray, gradient: np.ndarray | None = None) -> np.ndarray:
        """Lagrange multipliers of every exact constraint row at an equilibrium x: J^T lam = -grad Pi, least squares
        on the coordinates the rows touch (exact at an equilibrium; minimum norm for dependent rows)."""
        a = self.asm
        if not a.exact.m:
            return np.zeros(0)
        g = a.evaluate(x, hessian=False).gradient if gradient is None else gradient
        if not hasattr(self, "_mult_fixing"):  # structure only: decided once per problem
            A = a.exact.A.tocsr()
            A.sum_duplicates()
            simple = not len(a.exact.qrow) and np.all(np.diff(A.indptr) == 1) and \
                len(np.unique(A.indices)) == a.exact.m
            self._mult_fixing = (A.indices.copy(), A.data.copy()) if simple else None
        if self._mult_fixing is not None:  # supports fixing one coordinate each (distinct): lam_r = -g_c / a_r
            cols, coef = self._mult_fixing
            return -g[cols] / coef
        if not hasattr(self, "_mult_cols"):
            self._mult_cols = np.unique(np.r_[a.exact.A.tocsr().indices, a.exact.qi, a.exact.qj]).astype(np.int64)
            self._mult_J = a.exact.A.tocsc()[:, self._mult_cols].toarray() if not len(a.exact.qrow) else None
        cols = self._mult_cols
        Jd = self._mult_J if self._mult_J is not None else a.exact.jacobian(x).tocsc()[:, cols].toarray()
        if Jd.size > 4e6:  # many rows: sparse least squares
            return sp.linalg.lsqr(a.exact.jacobian(x).T, -g, atol=1e-15, btol=1e-15)[0]
        try:  # normal equations (m x m): the rows of supports and joints are independent
            return np.linalg.solve(Jd @ Jd.T, -(Jd @ g[cols]))
        except np.linalg.LinAlgError:  # dependent rows: the minimum-norm multipliers
            return np.linalg.lstsq(Jd.T, -g[cols], rcond=None)[0]

    def stability(self, x: np.ndarray, lam_g: np.ndarray | None = None) -> tuple[bool | None, np.ndarray | None]:
        """Is the reduced Hessian of the Lagrangian (on the tangent space of the exact constraints) positive definite?
        From the inertia of one sparse factorisation (statics/inertia.py), at every size. lam_g: multipliers of every exact
        row (default: from the gradient), for the curvature of the bilinear (rigid-joint) constraints.

        Returns (stable, direction of most negative curvature in full coordinates, max-norm 1)."""
        if self.light is not None:  # no multiplier rows: the reduced Hessian from the kernels
            if self.light.positive_definite(x, STABILITY_EPS):  # the usual case settled by a banded Cholesky
                return True, None
            inertia = reduced_inertia(self.light.tangent(x)[2])
            d = None if inertia.direction is None else self.S.full_v(inertia.direction)
            return inertia.stable, (d / np.max(np.abs(d)) if d is not None and np.any(d) else None)
        S = self.graph.S
        if S.mc:
            lam = self.multipliers(x) if lam_g is None else np.asarray(lam_g, float)
            S.lam[:] = lam[S.part.rows]
        S.x[:] = S.reduce(x)
        S.p[:] = -S.f_lin
        S.cm[:], S.cc[:], S.kc[:] = 0.0, 0.0, 1.0
        K = S.jacobian()
        nf = S.nf
        H, J = (K[:nf, :nf], K[nf:, :nf]) if S.mc else (K, None)
        inertia = reduced_inertia(H, J)
        d = None if inertia.direction is None else S.full_v(inertia.direction)
        return inertia.stable, (d / np.max(np.abs(d)) if d is not None and np.any(d) else None)

    def make_result(self, ok, status, iters, wall, x, stable, attempts, path, run) -> StaticResult:
        if ok and self._gaps:  # a penalty law that missed a surface between its points: no success
            _, found = contact_gap.hidden(self.asm, x)
            if found:
                ok, status = False, contact_gap.STATUS
                attempts.append({"method": "contact check", "status": status, "iterations": 0,
                                 "detail": contact_gap.refusal(found)})
        if not ok:  # never hand NaN to the caller: report the start point's energies with the failure
            x = x if np.all(np.isfinite(x)) else self.asm.x0
        res = StaticResult(status, ok, iters, wall, x, stable, attempts, self.asm, path if ok else "",
                           _work_out=functools.partial(self._result_details, x, ok))
        if run is not None:
            res.increment, res.energy_decrement = run.increment, run.energy_decrement
            res.residual, res.residual_floor = run.residual, run.residual_floor
        return res

    def _result_details(self, x: np.ndarray, ok: bool) -> tuple[dict, dict, float]:
        """A result's energies by label, reactions (multipliers of the exact rows at an equilibrium, penalty
        forces) and constraint violation at x."""
        a = self.asm
        ev = self._evaluation(x)
        forces: dict[str, list] = {}
        if ok and a.exact.m:
            for lbl, v in zip(a.exact.labels, self.multipliers(x, ev.gradient)):
                forces.setdefault(lbl, []).append(float(v))
        if a.penalty is not None:
            c = a.penalty.value(x)
            for lbl, k, cv in zip(a.penalty.labels, a.penalty.k, c):
                forces.setdefault(lbl, []).append(float(k * cv))
        viol = float(np.max(np.abs(a.constraints.value(x)))) if a.constraints.m else 0.0
        return ev.energies, forces, viol


_CACHE: "OrderedDict[bytes, StaticProblem]" = OrderedDict()


def problem_for(scene: Scene) -> StaticProblem:
    """The scene's StaticProblem, built once per scene content (scene.fingerprint: every value of the scene's data)
    and reused: a scene rebuilt with the same members, supports and loads skips the validation, the assembly and
    the Newton index maps (equal content was validated when its problem was built)."""
    key = fingerprint(scene)
    prob = _CACHE.get(key) if key is not None else None
    if prob is None:
        scene.validate_for_statics()
        prob = StaticProblem(scene)
        if key is not None:
            _CACHE[key] = prob
            if len(_CACHE) > CACHE_SIZE:
                _CACHE.popitem(last=False)
    else:
        _CACHE.move_to_end(key)
    return prob


def solve_static(scene: Scene | Assembly, options: StaticOptions | None = None,
                 warm_start: StaticResult | np.ndarray | None = None, **kw) -> StaticResult:
    """Static equilibrium of a scene. Keyword arguments are StaticOptions fields (tol, max_iter, load_steps,
    escape_saddle, print_level). warm_start: a previous result (same scene) or a coordinate vector."""
    opts = options or (StaticOptions(**kw) if kw else _DEFAULT_OPTIONS)
    x0 = warm_start.x if isinstance(warm_start, StaticResult) else warm_start
    prob = problem_for(scene) if isinstance(scene, Scene) else StaticProblem(scene)
    return prob.solve(opts, x0)
