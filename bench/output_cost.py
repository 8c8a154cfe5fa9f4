"""What a large statics run's outputs cost against its solve: the bundled cantilever (examples/scenes/cantilever.toml)
meshed with N elements, `ancf-sym run` through the command line (a fresh process: wall time of the whole command
against the solve's total that result.json states, wall_s.total = reading the scene + assembly + solve), then the
output stages one by one in this process on the same result (result.json, shape.png, fields.png, result.vtu).

Run: python bench/output_cost.py [N ...]   (default 150000)
The figure (150 000-element statics through the command line: wall time <= 3x the solve's total) and the log are in
bench/OUTPUT_RESULTS.md.
"""
from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SCENE = Path(__file__).resolve().parent.parent / "examples" / "scenes" / "cantilever.toml"


def scene_file(folder: Path, n: int) -> Path:
    text = SCENE.read_text().replace("elements = 18", f"elements = {n}")
    assert f"elements = {n}" in text
    path = folder / f"cantilever_{n}.toml"
    path.write_text(text)
    return path


def cli_run(path: Path, out: Path) -> dict:
    t = time.perf_counter()
    subprocess.run([sys.executable, "-m", "ancf_sym.cli", "run", str(path), "--out", str(out), "--quiet"], check=True)
    wall = time.perf_counter() - t
    doc = json.loads((out / "result.json").read_text())
    return {"wall": wall, "solve": doc["wall_s"]["solve"], "solve_total": doc["wall_s"]["total"]}


def stages(path: Path, out: Path) -> dict:
    from ancf_sym.io.json_out import static_result_dict, write_json
    from ancf_sym.io.plots import plot_fields, plot_shape
    from ancf_sym.io.scene_toml import load_scene
    from ancf_sym.statics import StaticProblem
    from ancf_sym.io.vtk import samples_per_element, write_vtu

    scene, analysis = load_scene(path)
    t = time.perf_counter()
    r = StaticProblem(scene).solve()
    times = {"assemble + solve (in process)": time.perf_counter() - t}
    per = samples_per_element(r.assembly.mesh, None)
    for name, f in (("result.json", lambda: write_json(out / "result.json", static_result_dict(r, path, analysis))),
                    ("shape.png", lambda: plot_shape(r, out / "shape.png")),
                    ("fields.png", lambda: plot_fields(r, out / "fields.png")),
                    (f"result.vtu ({per} samples per element)", lambda: write_vtu(r, out / "result.vtu", per))):
        t = time.perf_counter()
        f()
        times[name] = time.perf_counter() - t
    return times


def main(ns: list[int]) -> None:
    for n in ns:
        with tempfile.TemporaryDirectory() as tmp:
            tmp = Path(tmp)
            path = scene_file(tmp, n)
            c = cli_run(path, tmp / "out")
            print(f"{n} elements, `ancf-sym run`: wall {c['wall']:.2f} s; result.json: solve {c['solve']:.2f} s, "
                  f"solve's total (scene + assembly + solve) {c['solve_total']:.2f} s; wall / solve's total "
                  f"{c['wall'] / c['solve_total']:.2f}")
            (tmp / "stages").mkdir()
            s = stages(path, tmp / "stages")
            outputs = sum(v for k, v in s.items() if not k.startswith("assemble"))
            for k, v in s.items():
                print(f"  {k:40s} {v:6.2f} s")
            print(f"  {'outputs together':40s} {outputs:6.2f} s")


if __name__ == "__main__":
    main([int(a) for a in sys.argv[1:]] or [150_000])
