"""Cost of exact sensitivities of lines in water against the solve or run they differentiate.

Statics: examples/scenes/mooring_line.toml (a steel rope in a 0.6 m/s current) at n elements; timed (min over
repeats): the statics solve; StaticSensitivity (the water statics' linearisation, one factorisation) and every
reported quantity's derivative for water.density; the same for 9 parameters; the adjoint gradient of one output
(a coordinate of the line) for the 9. Dynamics: the taut line of tests/sensitivity/test_sensitivity_water.py in the
current and Airy waves (H 2 m, T 8 s), 400 generalized-alpha steps of 0.05 s from the reference; timed: the run
(simulate), the forward sensitivity for one parameter, the adjoint gradient of one output (the time integral of a
point's height) for 10 parameters.
Run: python bench/water_sensitivity_cost.py [--repeats N] [--elements 12 48] [--run-elements 10 40]
"""
import argparse
import copy
import time
import tomllib
from pathlib import Path

import numpy as np

from ancf_sym.dynamics import DynamicOptions, simulate
from ancf_sym.io.scene_toml import scene_from_dict
from ancf_sym.sensitivity.adjoint import SensorOutput, dynamic_gradient
from ancf_sym.sensitivity.dynamics import dynamic_sensitivity
from ancf_sym.sensitivity.static import StaticSensitivity
from ancf_sym.statics.problem import problem_for

ROOT = Path(__file__).resolve().parents[1]
MOORING = tomllib.loads((ROOT / "examples" / "scenes" / "mooring_line.toml").read_text())
STATIC_PATHS = ["water.density", "water.current[0]", "water.lines.line.cd", "water.lines.line.cd_axial",
                "materials.steel.E", "materials.steel.density", "sections.rope.diameter", "scene.gravity[1]",
                "members[0].prestrain"]
RUN_PATHS = ["water.density", "water.current[0]", "water.lines.line.cd", "water.lines.line.cd_axial",
             "water.lines.line.ca", "water.waves.height", "materials.steel.density", "materials.steel.E",
             "sections.rope.diameter", "water.lines.line.diameter"]


def best(f, repeats: int) -> float:
    ts = []
    for _ in range(repeats):
        t = time.perf_counter()
        f()
        ts.append(time.perf_counter() - t)
    return min(ts)


def statics(n: int, repeats: int) -> None:
    doc = copy.deepcopy(MOORING)
    doc["members"][0]["elements"] = n
    scene, _ = scene_from_dict(doc)
    r = problem_for(scene).solve()
    ts = best(lambda: problem_for(scene).solve(), repeats)
    t1 = best(lambda: StaticSensitivity(scene, r, doc).derivative("water.density"), repeats)

    def all_paths():
        s = StaticSensitivity(scene, r, doc)
        return [s.derivative(p) for p in STATIC_PATHS]
    tn = best(all_paths, repeats)
    dJ = np.zeros(len(r.x))
    dJ[len(r.x) // 2] = 1.0
    ta = best(lambda: StaticSensitivity(scene, r, doc).gradient(dJ, STATIC_PATHS), repeats)
    k = len(STATIC_PATHS)
    print(f"statics, {n} elements: solve {ts * 1e3:.1f} ms; one parameter, all outputs {t1 / ts:.2f}x; {k} "
          f"parameters, all outputs {tn / ts:.2f}x; one output, {k} parameters (adjoint) {ta / ts:.2f}x")


def run(n: int, repeats: int) -> None:
    doc = copy.deepcopy(MOORING)
    doc["members"][0].update(elements=n, prestrain=0.002)
    doc["water"]["lines"]["line"].update(ca_axial=1.0, diameter=0.04)
    doc["water"]["waves"] = {"height": 2.0, "period": 8.0}
    o = DynamicOptions(dt=0.05, t_end=20.0, sensors=[{"name": "mid", "kind": "position", "member": "line",
                                                      "at": n // 2}])
    out = SensorOutput("mid", 1, "integral")
    simulate(scene_from_dict(doc)[0], o)  # (warm: the compiled step graphs)
    dynamic_gradient(doc, RUN_PATHS, o, out)
    tr = best(lambda: simulate(scene_from_dict(doc)[0], o), repeats)
    tf = best(lambda: dynamic_sensitivity(doc, RUN_PATHS[:1], o), repeats)
    ta = best(lambda: dynamic_gradient(doc, RUN_PATHS, o, out), repeats)
    print(f"run, {n} elements, 400 steps: {tr:.3f} s; forward, one parameter {tf / tr:.2f}x; one output, "
          f"{len(RUN_PATHS)} parameters (adjoint) {ta / tr:.2f}x")


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--elements", type=int, nargs="*", default=[12, 48])
    ap.add_argument("--run-elements", type=int, nargs="*", default=[10, 40])
    a = ap.parse_args()
    for n in a.elements:
        statics(n, a.repeats)
    for n in a.run_elements:
        run(n, max(1, a.repeats // 2))
