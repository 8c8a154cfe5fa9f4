"""Shared plumbing of the examples: command line, JSON records, stdout tables, matplotlib figures, small helpers.

Every example exposes `main(argv=None) -> list[dict]` and takes
    --json PATH   write the records (a JSON list of flat dicts, one per case)
    --quick       the small version the test suite runs (a few seconds)
    --out DIR     PNG figures (default examples/out/<name>/)
    --no-plots    skip the figures
"""
from __future__ import annotations

import os

# One BLAS thread, set before numpy loads OpenBLAS: casadi's wheel brings its own OpenBLAS, and the two thread pools
# busy-wait against each other on a small loaded machine. Measured on 2 shared cores: numpy.linalg.eigh of a 256 x 256
# matrix (StaticProblem.stability's dense eigen-decomposition at 64 elements) took 2.2 s after `import casadi`, 0.018 s
# with one thread. Import this module before numpy for it to act; an explicit environment setting wins.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent


def parser(name: str, doc: str) -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog=f"{name}.py", description=doc.strip().splitlines()[0])
    p.add_argument("--json", metavar="PATH", help="write the records as a JSON list")
    p.add_argument("--quick", action="store_true", help="small version (the test suite's)")
    p.add_argument("--out", metavar="DIR", default=str(HERE / "out" / name), help="directory for PNG figures")
    p.add_argument("--no-plots", action="store_true", help="do not draw figures")
    return p


def _plain(v):
    """JSON-safe scalar: numpy scalars to Python, NaN/inf to None."""
    if isinstance(v, (np.bool_, bool)):
        return bool(v)
    if isinstance(v, (np.integer,)):
        return int(v)
    if isinstance(v, (float, np.floating)):
        v = float(v)
        return v if math.isfinite(v) else None
    return v


def write_json(records: list[dict], path: str | None) -> None:
    if not path:
        return
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w") as f:
        json.dump([{k: _plain(v) for k, v in r.items()} for r in records], f, indent=1)


def finish(records: list[dict], args, plots, *data) -> list[dict]:
    """The end of a main(): write the records to --json and, unless --no-plots, draw plots(*data, args.out)."""
    write_json(records, args.json)
    if not args.no_plots:
        plots(*data, args.out)
    return records


def find(records: list[dict], **kw) -> dict:
    """The first record whose fields equal kw (KeyError if none)."""
    for r in records:
        if all(r.get(k) == v for k, v in kw.items()):
            return r
    raise KeyError(kw)


def table(records: list[dict], columns: list[str], title: str | None = None, fmt: dict | None = None) -> str:
    """A small fixed-width table of the given record fields (missing fields blank); printed and returned."""
    fmt = fmt or {}

    def cell(r, c):
        if c not in r:
            return ""
        v = r[c]
        if v is None:
            return "-"
        if c in fmt:
            return fmt[c].format(v)
        if isinstance(v, (float, np.floating)):
            return f"{v:.6g}"
        return str(v)

    rows = [[cell(r, c) for c in columns] for r in records]
    w = [max([len(c)] + [len(row[i]) for row in rows]) for i, c in enumerate(columns)]
    lines = ([title] if title else []) + ["  ".join(c.rjust(w[i]) for i, c in enumerate(columns)),
                                          "  ".join("-" * x for x in w)]
    lines += ["  ".join(row[i].rjust(w[i]) for i in range(len(columns))) for row in rows]
    text = "\n".join(lines)
    print(text + "\n", flush=True)
    return text


def pyplot():
    """matplotlib.pyplot on the Agg backend (no display needed)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def save(fig, out: str, name: str) -> str:
    os.makedirs(out, exist_ok=True)
    path = os.path.join(out, name)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    fig.clf()
    import matplotlib.pyplot as plt
    plt.close(fig)
    print(f"figure: {path}")
    return path


def attempts_text(result) -> str:
    """The solver's attempts in one line: 'full steps:Solve_Succeeded(20); leave saddle (0.001 L):...(98)'."""
    return "; ".join(f"{a['method']}:{a['status']}({a['iterations']})" for a in result.attempts)


def turn_angle(t0: np.ndarray, t1: np.ndarray) -> float:
    """Signed angle [rad] from planar vector t0 to t1."""
    return float(math.atan2(t0[0] * t1[1] - t0[1] * t1[0], t0 @ t1))


def first_minimum(t: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """(time, value) of the first local minimum of the sampled y(t), refined by a parabola through the sample and its
    neighbours; (nan, nan) if y has none."""
    d = np.diff(y)
    k = np.flatnonzero((d[:-1] < 0) & (d[1:] >= 0))
    if not len(k):
        return float("nan"), float("nan")
    i = int(k[0]) + 1
    y0, y1, y2 = y[i - 1], y[i], y[i + 1]
    den = y0 - 2 * y1 + y2
    s = 0.5 * (y0 - y2) / den if den else 0.0
    return float(t[i] + s * (t[i + 1] - t[i])), float(y1 - 0.25 * (y0 - y2) * s)
