"""Benchmark: how long the kernels take to compile, and how long a whole `pip install .` takes.

    python bench/compile_times.py                 # every generated/*.c, one at a time, flags from the manifest
    python bench/compile_times.py --setuptools    # ... with the flags setuptools really adds (python's CFLAGS)
    python bench/compile_times.py --pip           # also: fresh venv, `pip install <clean copy of the project>`

Each file is compiled exactly as setup.py's Extension asks: `gcc -fPIC -shared <manifest cflags> file.c -lm`
(--setuptools prepends python's sysconfig CFLAGS, e.g. `-g -fwrapv -O3 -Wall`, which setuptools passes before
the extension's own flags: the manifest's -O2 still wins, but -g makes gcc write debug information).
The per-file times are serial; "wall, N jobs" is the same set compiled N at a time, as setup.py's build_ext does
on every core. The requirement is a whole install <= 3 minutes on a 2-core machine.
"""
from __future__ import annotations

import argparse
import json
import os
import shlex
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def compile_one(src: Path, flags: list[str], out_dir: Path, cc: str = "gcc") -> float:
    cmd = [cc, "-fPIC", "-shared", *flags, str(src), "-o", str(out_dir / (src.stem + ".so")), "-lm"]
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True)
    return time.perf_counter() - t0


def compile_all(root: Path, extra: list[str], jobs: int) -> tuple[dict[str, float], float, float]:
    manifest = json.loads((root / "generated" / "manifest.json").read_text())
    files = {k["c_file"]: k["cflags"] for k in manifest["kernels"]}  # several kernels share one file
    entries = [(root / "generated" / f, extra + flags) for f, flags in files.items()]
    entries.sort(key=lambda e: -e[0].stat().st_size)  # largest first, as setup.py orders the build
    with tempfile.TemporaryDirectory() as tmp:
        times = {}
        for src, flags in entries:
            times[src.name] = compile_one(src, flags, Path(tmp))
            print(f"  {src.name:40s} {times[src.name]:7.2f} s  ({' '.join(flags)})", file=sys.stderr, flush=True)
        serial = sum(times.values())
        t0 = time.perf_counter()
        if jobs > 1:  # longest first, as a good scheduler would
            order = sorted(entries, key=lambda e: -times[e[0].name])
            with ThreadPoolExecutor(jobs) as pool:
                list(pool.map(lambda e: compile_one(e[0], e[1], Path(tmp)), order))
        wall = time.perf_counter() - t0 if jobs > 1 else serial
    return times, serial, wall


def pip_install_time(root: Path, python: str) -> dict[str, float]:
    """Fresh venv; install the dependencies (from pip's local cache/wheels), then time `pip install <copy>`."""
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        src = tmp / "src"
        shutil.copytree(root, src, ignore=shutil.ignore_patterns(".git", "build", "dist", "*.egg-info", "__pycache__",
                                                                 "*.so", ".pytest_cache", "out"))
        t0 = time.perf_counter()
        subprocess.run([python, "-m", "venv", str(tmp / "venv")], check=True)
        out["venv"] = time.perf_counter() - t0
        pip = [str(tmp / "venv" / "bin" / "python"), "-m", "pip", "install", "-q"]
        deps = ["casadi==3.8.2", "numpy", "scipy", "matplotlib", "tqdm", "meshio"]
        t0 = time.perf_counter()
        subprocess.run(pip + deps, check=True)
        out["dependencies"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        subprocess.run(pip + [str(src)], check=True)
        out["pip install ."] = time.perf_counter() - t0
        out["total"] = out["venv"] + out["dependencies"] + out["pip install ."]
        check = subprocess.run([str(tmp / "venv" / "bin" / "python"), "-c",
                                "from ancf_sym import kernels; print(len(kernels.catalogue()))"],
                               cwd=tmp, check=True, capture_output=True, text=True)
        out["kernels loadable"] = int(check.stdout.strip())
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--root", type=Path, default=ROOT, help="project root (holds generated/)")
    ap.add_argument("--setuptools", action="store_true", help="prepend python's CFLAGS as setuptools does")
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="parallel compile for the wall time")
    ap.add_argument("--pip", action="store_true", help="also time a full pip install into a fresh venv")
    ap.add_argument("--python", default=sys.executable, help="interpreter for the fresh venv")
    args = ap.parse_args(argv)

    extra = shlex.split(sysconfig.get_config_var("CFLAGS") or "") if args.setuptools else []
    times, serial, wall = compile_all(args.root, extra, args.jobs)
    print(f"flags: gcc -fPIC -shared {' '.join(extra)} <manifest cflags> file.c -lm")
    print(f"gcc: {subprocess.run(['gcc', '--version'], capture_output=True, text=True).stdout.splitlines()[0]}")
    print("\n| file | lines | seconds |\n|---|---|---|")
    for name, t in sorted(times.items(), key=lambda kv: -kv[1]):
        lines = sum(1 for _ in open(args.root / "generated" / name))
        print(f"| {name} | {lines} | {t:.2f} |")
    print(f"| **total, serial ({len(times)} files)** | | **{serial:.1f}** |")
    if args.jobs > 1:
        print(f"| **wall, {args.jobs} jobs** | | **{wall:.1f}** |")
    if args.pip:
        res = pip_install_time(args.root, args.python)
        print("\n| fresh-venv install step | seconds |\n|---|---|")
        for k, v in res.items():
            print(f"| {k} | {v:.1f} |" if isinstance(v, float) else f"| {k} | {v} |")
        verdict = "meets" if res["total"] <= 180 else "MISSES"
        print(f"\nwhole install {res['total']:.0f} s: {verdict} the <= 180 s requirement")


if __name__ == "__main__":
    main()
