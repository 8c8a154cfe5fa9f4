"""The result of a dynamic run: status, outputs (times, sensors, energies, constraint violation), counters."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ancf_sym.model.assembly import Assembly
from ancf_sym.util.names import NamedDict
from ancf_sym.dynamics.options import DynamicOptions


@dataclass
class DynamicResult:
    status: str  # "completed" | "newton_failed" | "step_size_underflow" | "energy_blowup" | "contact_penetration_hidden"
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
    # per drive (ancf_sym.bodies.drives): what it applies at the output times, (len(t), k): an angle drive's torque on its
    # body [N m], a position drive's force [N] (from the multipliers; linear in time between steps)
    drive_reactions: dict = field(default_factory=dict)
    # per penalty contact (ancf_sym.contact.gap.Watch.record): the smallest true gap of the centre line over every
    # accepted step [m] (None: never below 0), its time [s] and the law's sampled penetration then [m]
    contact_gaps: list = field(default_factory=list)
    # (len(t), n) every coordinate at the output times where options.record_states asked for them, else None
    states: np.ndarray | None = None
    # contact scenes: accepted steps taken on the contact-free step graph while no element was in reach of a surface
    # (ancf_sym.dynamics.reach)
    steps_out_of_reach: int = 0

    def __post_init__(self) -> None:
        # a wrong sensor or energy name is refused listing the names there are
        self.sensors = NamedDict(self.sensors, kind="sensor")
        self.energies = NamedDict(self.energies, kind="energy label")
        self.drive_reactions = NamedDict(self.drive_reactions, kind="drive")

    def summary(self) -> str:
        """One line: status, time reached, steps, Newton iterations, wall time."""
        return (f"{self.integrator} {self.status}" + ("" if self.success else f" ({self.message})")
                + f" at t = {self.t_reached:.6g} s: {self.steps} steps, {len(self.rejected)} rejected, "
                f"{self.newton_iterations} Newton iterations, {self.wall_s:.3g} s (+ {self.setup_s:.3g} s setup)")

    def __repr__(self) -> str:
        return (f"<DynamicResult {self.summary()}; {len(self.t)} output times; sensors {list(self.sensors)}; "
                f"energies {list(self.energies)}>")

    def _repr_html_(self) -> str:
        from ancf_sym.util.html import html_table
        err = self.energy_error()
        return html_table("DynamicResult", self.summary(), [
            ("status", self.status), ("integrator", self.integrator), ("t reached", f"{self.t_reached:.6g} s"),
            ("steps (rejected)", f"{self.steps} ({len(self.rejected)})"), ("Newton iterations", self.newton_iterations),
            ("wall time (setup)", f"{self.wall_s:.3g} s ({self.setup_s:.3g} s)"), ("output times", len(self.t)),
            ("sensors", ", ".join(self.sensors) or "-"), ("energies", ", ".join(self.energies) or "-"),
            ("energy error", "-" if err is None else f"{err:.2g}")])

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
            **({"contact_gaps": self.contact_gaps} if self.contact_gaps else {}),
        }

