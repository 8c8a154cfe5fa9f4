"""Cost per step of ground contact: the same 1 m rope (40 cable2d elements, generalized-alpha, dt = 1e-3, 1 s)
falling freely (no contact declared), onto a penalty ground (normal law only), and onto a ground with damping and
friction (the dissipation kernels, unsymmetric tangent: sparse QR); and the normal law alone solved by QR, to
separate the linear solver's share from the kernels'. Prints min/median wall time per step over
repeats, Newton iterations per step and the set-up time of the step graphs.

Run: python bench/contact_cost.py [--repeats 3]
"""
from __future__ import annotations

import argparse
import os
import statistics

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from ancf_sym import Material, Scene, Section  # noqa: E402
from ancf_sym.model.assembly import Assembly  # noqa: E402
from ancf_sym.dynamics import DynamicOptions, simulate  # noqa: E402
from ancf_sym.system.step_system import StepSystem  # noqa: E402

CASES = {
    "no contact": ({}, "auto"),
    "ground, normal law": (dict(stiffness=1e4), "auto"),
    "ground, normal law, QR solve": (dict(stiffness=1e4), "qr"),  # where the friction case's time goes
    "ground + damping + friction": (dict(stiffness=1e4, damping=3e4, mu=0.3, eps=1e-2), "auto"),
}


def scene(options: dict) -> Scene:
    sc = Scene(dim=2, gravity=(0.0, -9.81))
    sc.member("rope", [(0.0, 0.05), (1.0, 0.05)], 40, Material(E=2e9, density=1000.0), Section.circle(0.01))
    if options:
        sc.contact_ground("rope", **options)
    return sc


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=3)
    a = ap.parse_args()
    print(f"{'case':30s} {'min us/step':>12s} {'median':>10s} {'Newton/step':>12s} {'setup s':>8s}")
    base = None
    for name, (opts, linsol) in CASES.items():
        walls, setups = [], []
        for _ in range(a.repeats):
            asm = Assembly(scene(opts))
            system = StepSystem(asm, linsol=linsol)
            res = simulate(asm, DynamicOptions(dt=1e-3, t_end=1.0, energies=False), system=system)
            walls.append(res.wall_s / res.steps * 1e6)
            setups.append(res.setup_s)
        it = res.counters["newton_iterations"] / res.steps
        base = base or min(walls)
        print(f"{name:30s} {min(walls):12.1f} {statistics.median(walls):10.1f} {it:12.2f} {min(setups):8.2f}"
              f"   x{min(walls) / base:.2f}")


if __name__ == "__main__":
    main()
