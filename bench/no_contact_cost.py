"""Cost of a scene without contact, with and without the contact machinery in the package (effects on demand).

The same scenes without any contact are stepped by this checkout's installed ancf_sym and by a baseline build of
the package from before contact existed (`--baseline DIR`: a directory holding that build, see below), each in its
own process, interleaved, min and median over --repeats. Scenes: a 1 m rope of 40 cable2d elements falling under
gravity (bench/contact_cost.py's "no contact" case) and a pinned 2 m cable3d pendulum of 40 elements; generalized-
alpha, dt = 1e-3 s, 1 s. Printed per scene and build: CPU time per step, Newton iterations per step, and the size of
the compiled Newton-iteration graph (instructions, inputs): a scene that declares no contact gets the same graph.

Baseline build (the commit before ground contact was added; a few minutes of C compilation), in two directories
outside the project root, SRC and SITE:
    git archive <commit> | tar -x -C SRC
    pip install --no-deps --target SITE SRC

Run: python bench/no_contact_cost.py [--baseline SITE] [--repeats 3] [--json PATH]
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys

RUNNER = r"""
import json, os, sys, time
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
import ancf_sym
from ancf_sym import DynamicOptions, Material, Scene, Section, simulate
from ancf_sym.model.assembly import Assembly
from ancf_sym.system.step_system import StepSystem

def rope():
    s = Scene(dim=2, gravity=(0.0, -9.81))
    s.member("rope", [(0.0, 0.05), (1.0, 0.05)], 40, Material(E=2e9, density=1000.0), Section.circle(0.01))
    return s

def pendulum():
    s = Scene(dim=3, gravity=(0.0, 0.0, -9.81))
    s.member("cable", [(0.0, 0.0, 0.0), (2.0, 0.0, 0.0)], 40, Material(E=2e9, density=1000.0),
             Section.circle(0.01), element="cable3d")
    s.pin("cable", "start")
    return s

out = {"package": os.path.dirname(ancf_sym.__file__)}
for name, make in (("rope2d", rope), ("pendulum3d", pendulum)):
    asm = Assembly(make())
    S = StepSystem(asm)  # (no damping declared: the system the run builds)
    res = simulate(asm, DynamicOptions(dt=1e-3, t_end=1.0, energies=False))
    g = S.iter_f
    out[name] = {"cpu_us_step": res.cpu_s / res.steps * 1e6, "newton_per_step":
                 res.counters["newton_iterations"] / res.steps, "status": res.status,
                 "graph_instructions": g.n_instructions(), "graph_inputs": g.n_in(), "unknowns": S.nf}
print(json.dumps(out))
"""


def run(site: str | None) -> dict:
    env = dict(os.environ)
    if site:
        env["PYTHONPATH"] = site + os.pathsep + env.get("PYTHONPATH", "")
    p = subprocess.run([sys.executable, "-c", RUNNER], env=env, capture_output=True, text=True, cwd="/")
    if p.returncode:
        raise RuntimeError(f"runner failed ({site or 'installed'}):\n{p.stderr[-2000:]}")
    return json.loads(p.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--baseline", help="directory of a baseline build (pip install --target) to compare against")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json")
    a = ap.parse_args()
    builds = {"this checkout": None}
    if a.baseline:
        builds["baseline (before contact)"] = a.baseline
    runs: dict = {b: [] for b in builds}
    for _ in range(a.repeats):  # interleaved
        for b, site in builds.items():
            runs[b].append(run(site))
    rows = []
    for scene in ("rope2d", "pendulum3d"):
        for b, rs in runs.items():
            per = [r[scene]["cpu_us_step"] for r in rs]
            r0 = rs[0][scene]
            rows.append(dict(scene=scene, build=b, cpu_us_step_min=min(per),
                             cpu_us_step_median=statistics.median(per), newton_per_step=r0["newton_per_step"],
                             graph_instructions=r0["graph_instructions"], graph_inputs=r0["graph_inputs"],
                             unknowns=r0["unknowns"], status=r0["status"]))
    print(f"scenes without contact, generalized-alpha dt = 1e-3 s, 1 s; CPU time per step, min/median over "
          f"{a.repeats} repeats (interleaved processes)")
    print(f"{'scene':11s} {'build':26s} {'min us/step':>12s} {'median':>8s} {'ratio':>6s} {'Newton/step':>11s} "
          f"{'graph instr.':>12s} {'inputs':>6s}")
    base = {}
    for r in rows:
        base.setdefault(r["scene"], r["cpu_us_step_min"])
        print(f"{r['scene']:11s} {r['build']:26s} {r['cpu_us_step_min']:12.1f} {r['cpu_us_step_median']:8.1f} "
              f"{r['cpu_us_step_min'] / base[r['scene']]:6.2f} {r['newton_per_step']:11.2f} "
              f"{r['graph_instructions']:12d} {r['graph_inputs']:6d}")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
