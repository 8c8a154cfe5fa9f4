"""The Lowe & Langley jumper's dynamic case 1 beside MoorDyn: the top end moved in surge, x(t) = x0 + f(t) A sin(2 pi t
/ T), A = 10 m, T = 27 s, with MoorDyn's test ramp f (smootherstep over the first period), 27 + 80 s simulated.

Both codes from their static state (this package: ancf_sym.statics.water from the hinged-V warm start of
examples/lowe_langley_jumper.py; MoorDyn: its stationary initial-condition solve), the same line data (MoorDyn's
test input: D 0.396 m, 165 kg/m, EA 500e6 N, axial damping 0.5 of critical per segment, EI 120.8e3 N m^2,
Cd = Ca = 1, CdAx = CaAx = 0, water 1000 kg/m^3, g 9.807, depth 100 m). This package: generalized-alpha at its own
step (implicit: --dt, default 0.25 s), n elements (--n, default 34), the axial damping as strain-rate damping with
MoorDyn's coefficient BA = zeta l_seg sqrt(EA m) of its 68 segments. MoorDyn: its test's dtM = 1 ms (midpoint5),
coupled every 5 ms.

Records: ratio (this package's CPU time of the run, its step graphs' set-up included, over MoorDyn's of its steps
after its initial-condition solve; the same simulated time),
tension_rel_diff (largest relative difference of the top tension histories, |F_top|, at this package's output
times after the ramp), the CPU times, the steps.

Needs `pip install moordyn` (the bench extra). Run: python bench/mooring_vs_moordyn.py [--json PATH] [--dt S] [--n N]
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "examples"))
sys.path.insert(0, str(ROOT / "bench"))

import numpy as np  # noqa: E402

import lowe_langley_jumper as J  # noqa: E402
from moordyn_jumper import top_tension  # noqa: E402

RAMP = J.PERIOD

def ours(n: int, dt: float) -> dict:
    return J.dynamic_case1(n, dt)


def moordyn(times: np.ndarray) -> dict:
    return top_tension(times, surge=lambda t: J.surge(t)[0])


def main(argv=None) -> dict:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--json", metavar="PATH")
    p.add_argument("--dt", type=float, default=0.25)
    p.add_argument("--n", type=int, default=34)
    a = p.parse_args(argv)
    mine = ours(a.n, a.dt)
    theirs = moordyn(mine["t"])
    after = mine["t"] >= RAMP
    rel = np.abs(mine["tension"] - theirs["tension"]) / np.abs(theirs["tension"])
    rec = dict(case="lowe_langley_case1", n=a.n, dt=a.dt, steps=mine["steps"], status=mine["status"],
               cpu_s=mine["cpu_s"], moordyn_cpu_s=theirs["cpu_s"],
               ratio=mine["cpu_s"] / theirs["cpu_s"], tension_rel_diff=float(np.max(rel[after])),
               tension_rel_diff_all=float(np.max(rel)),
               top_tension_max_kN=float(np.max(mine["tension"][after]) / 1e3),
               top_tension_max_moordyn_kN=float(np.max(theirs["tension"][after]) / 1e3))
    print(json.dumps(rec, indent=1))
    if a.json:
        Path(a.json).write_text(json.dumps(rec, indent=1))
    return rec


if __name__ == "__main__":
    main()
