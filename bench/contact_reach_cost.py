"""What a contact costs where it does not touch, and what friction costs where it does: the figures a broad phase
and reduced friction kernels are judged by. All in one process, interleaved, CPU time of the time loop per step,
min / median over --repeats.

Scenes: a 1 m rope of 40 cable2d elements (round 10 mm, E = 2 GPa, rho = 1000 kg/m^3), generalized-alpha,
dt = 1e-3 s, 0.5 s.
- untouched: the rope falls from y = 0.05 m with a contact it never reaches (ground 10 m below; a drum of radius
  1 m centred 10 m below), normal law alone and with damping and friction; ratio to the plain falling rope.
- sliding: the rope lies on the ground (at its static penetration) sliding at 1 m/s; frictionless, damping alone,
  friction (mu 0.3, eps 1e-3 m/s) with damping; ratio to the frictionless slide.

Run: python bench/contact_reach_cost.py [--repeats 5]
"""
from __future__ import annotations

import argparse
import os
import statistics

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from ancf_sym import Material, Scene, Section  # noqa: E402
from ancf_sym.model.assembly import Assembly  # noqa: E402
from ancf_sym.dynamics import DynamicOptions, simulate  # noqa: E402

D, K, RHO, G = 0.01, 1e4, 1000.0, 9.81
W = RHO * np.pi * (D / 2) ** 2 * G  # weight per metre
FRICTION = dict(damping=3e4, mu=0.3, eps=1e-3)


def rope(y: float) -> Scene:
    sc = Scene(dim=2, gravity=(0.0, -G))
    sc.member("rope", [(0.0, y), (1.0, y)], 40, Material(E=2e9, density=RHO), Section.circle(D))
    return sc


def untouched(kind: str | None, extra: dict) -> tuple[Scene, None]:
    sc = rope(0.05)
    if kind == "ground":
        sc.contact_ground("rope", stiffness=K, level=-10.0, **extra)
    elif kind == "drum":
        sc.contact_drum("rope", centre=(0.5, -10.0), radius=1.0, stiffness=K, **extra)
    return sc, None


def sliding(extra: dict) -> tuple[Scene, str]:
    sc = rope(D / 2 - W / K)
    sc.contact_ground("rope", stiffness=K, **extra)
    return sc, "slide"


CASES = {
    "plain rope (falling)": lambda: untouched(None, {}),
    "untouched ground, normal law": lambda: untouched("ground", {}),
    "untouched ground + damping + friction": lambda: untouched("ground", FRICTION),
    "untouched drum, normal law": lambda: untouched("drum", {}),
    "untouched drum + damping + friction": lambda: untouched("drum", FRICTION),
    "sliding on ground, frictionless": lambda: sliding({}),
    "sliding on ground, damping alone": lambda: sliding(dict(damping=3e4)),
    "sliding on ground + damping + friction": lambda: sliding(FRICTION),
}
BASE = {"plain rope (falling)": "untouched", "sliding on ground, frictionless": "sliding"}


def run(make) -> tuple[float, float, int]:
    sc, mode = make()
    asm = Assembly(sc)
    v = None
    if mode == "slide":
        v = np.zeros(asm.n)
        v[0::4] = 1.0  # x-velocity of every node (cable2d node: x, y, r_x, r_y)
    res = simulate(asm, DynamicOptions(dt=1e-3, t_end=0.5, energies=False, v0=v))
    assert res.success, res.message
    return res.cpu_s / res.steps * 1e6, res.counters["newton_iterations"] / res.steps, res.counters.get(
        "rejected_steps", 0)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=5)
    a = ap.parse_args()
    times: dict = {n: [] for n in CASES}
    its = {}
    for n, make in CASES.items():  # warm-up: build (and cache) every step graph before timing
        run(make)
    for _ in range(a.repeats):  # interleaved: load from other processes spreads over all cases alike
        for n, make in CASES.items():
            t, it, _ = run(make)
            times[n].append(t)
            its[n] = it
    print(f"CPU us/step of the time loop, min / median over {a.repeats} interleaved repeats")
    print(f"{'case':40s} {'min':>8s} {'median':>8s} {'Newton/step':>11s} {'ratio min':>9s} {'ratio med':>9s}")
    base = None
    for n in CASES:
        if n in BASE:
            base = n
        r_min = min(times[n]) / min(times[base])
        r_med = statistics.median(times[n]) / statistics.median(times[base])
        print(f"{n:40s} {min(times[n]):8.1f} {statistics.median(times[n]):8.1f} {its[n]:11.2f} {r_min:9.2f} "
              f"{r_med:9.2f}")


if __name__ == "__main__":
    main()
