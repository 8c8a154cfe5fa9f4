"""A study's report: results.csv, report.md (table, convergence rates, the cheapest setting reaching the target)
and two figures: error vs wall time (log-log, Pareto front marked) and error vs the refinement axis with the
observed convergence rate."""
from __future__ import annotations

import csv
import math
import textwrap
from pathlib import Path

import numpy as np

from .base import Study


def _ok(r: dict) -> bool:
    e, t = r.get("error"), r.get("wall_s")
    return bool(r.get("success")) and e is not None and t is not None and math.isfinite(e) and math.isfinite(t)


TIE = 0.1  # relative time difference below which two settings count as equally expensive in the answer


def pareto_front(records: list[dict]) -> list[dict]:
    """The settings no other setting beats in both wall time and error (sorted by time)."""
    pts = sorted((r for r in records if _ok(r)), key=lambda r: (r["wall_s"], r["error"]))
    front, best = [], math.inf
    for r in pts:
        if r["error"] < best:
            front.append(r)
            best = r["error"]
    return front


def cheapest(records: list[dict], target: float) -> dict | None:
    ok = [r for r in records if _ok(r) and r["error"] <= target]
    return min(ok, key=lambda r: r["wall_s"]) if ok else None


def group_label(study: Study, r: dict, axis: str | None = None) -> str:
    """The setting without the refinement axis (default: the study's element-count axis)."""
    axis = axis or study.refine_axis
    return ", ".join(f"{a.name}={r[a.name]}" for a in study.axes if a.name != axis) or "all"


def convergence_rates(study: Study, records: list[dict], floor: float = 0.0, axis: str | None = None,
                      shrinks: bool = False) -> dict[str, float | None]:
    """Observed order per group over the three finest values of `axis` (default the element count) above 3x the
    reference's error: error ~ n^-p (slope -p), or for a step-size axis (shrinks=True) error ~ dt^p."""
    axis = axis or study.refine_axis
    if axis is None:
        return {}
    groups: dict[str, list] = {}
    for r in records:
        if _ok(r) and r["error"] > 3 * floor:
            groups.setdefault(group_label(study, r, axis), []).append((float(r[axis]), r["error"]))
    rates = {}
    for g, pts in groups.items():
        pts = sorted(pts, reverse=shrinks)[-3:]
        if len(pts) < 2 or min(p[1] for p in pts) <= 0:
            rates[g] = None
            continue
        x, y = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
        slope = float(np.polyfit(x, y, 1)[0])
        rates[g] = slope if shrinks else -slope
    return rates


def finest_mesh(study: Study, records: list[dict]) -> list[dict]:
    """The records at the largest value of the element-count axis (all records if the study has none)."""
    if not study.refine_axis or not records:
        return records
    top = max(r[study.refine_axis] for r in records)
    return [r for r in records if r[study.refine_axis] == top]


def _fmt(v) -> str:
    if v is None:
        return "-"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def setting_text(study: Study, r: dict) -> str:
    return ", ".join(f"{a.name} = {r[a.name]}" for a in study.axes)


def write_csv(path: Path, study: Study, records: list[dict]) -> list[str]:
    cols = [a.name for a in study.axes] + ["error", "wall_s", *study.columns, "status"]
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(cols)
        for r in records:
            w.writerow(["" if r.get(c) is None else r.get(c) for c in cols])
    return cols


def write_plots(out: Path, study: Study, records: list[dict], target: float, rates: dict) -> list[str]:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = [r for r in records if _ok(r) and r["error"] > 0]
    files = []
    groups = sorted({group_label(study, r) for r in ok})
    colors = {g: plt.cm.tab10(i % 10) for i, g in enumerate(groups)}
    markers = "osD^v<>phX*"
    fig, ax = plt.subplots(figsize=(7.5, 5))
    for i, g in enumerate(groups):
        pts = [r for r in ok if group_label(study, r) == g]
        ax.loglog([r["wall_s"] for r in pts], [r["error"] for r in pts], markers[i % len(markers)], color=colors[g],
                  label=g, ms=5, alpha=0.85)
    front = [r for r in pareto_front(records) if r["error"] > 0]
    if front:
        ax.loglog([r["wall_s"] for r in front], [r["error"] for r in front], "k-", lw=1.2, label="Pareto front",
                  drawstyle="steps-post")
    ax.axhline(target, color="0.4", ls=":", lw=1, label=f"target {target:g}")
    ax.set_xlabel(study.extra.get("time_label", "wall time per setting [s]"))
    ax.set_ylabel(study.error_name)
    ax.set_title(textwrap.fill(f"{study.title}: error vs time", 70), fontsize=10)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(out / "error_vs_time.png", dpi=120)
    plt.close(fig)
    files.append("error_vs_time.png")
    for axis, axis_rates in rates.items():
        fig, ax = plt.subplots(figsize=(7.5, 5))
        sub = sorted(axis_rates) if axis == study.step_axis else sorted({group_label(study, r, axis) for r in ok})
        if not sub:
            plt.close(fig)
            continue
        for i, g in enumerate(sub):
            pts = sorted((float(r[axis]), r["error"]) for r in ok if group_label(study, r, axis) == g)
            rate = axis_rates.get(g)
            lab = g + (f" (rate {rate:.2f})" if rate is not None else "")
            ax.loglog([p[0] for p in pts], [p[1] for p in pts], markers[i % len(markers)] + "-",
                      color=plt.cm.tab10(i % 10), label=lab, ms=4, lw=1)
        ax.axhline(target, color="0.4", ls=":", lw=1, label=f"target {target:g}")
        ax.set_xlabel(axis)
        ax.set_ylabel(study.error_name)
        ax.set_title(textwrap.fill(f"{study.title}: convergence in {axis}", 70), fontsize=10)
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7, ncol=2)
        fig.tight_layout()
        fig.savefig(out / f"error_vs_{axis}.png", dpi=120)
        plt.close(fig)
        files.append(f"error_vs_{axis}.png")
    return files


def write_report(out: Path, study: Study, records: list[dict], reference: dict, target: float, meta: dict,
                 planned: int) -> str:
    """Write results.csv, the figures and report.md; returns the one-line answer."""
    floor = float(reference.get("error_bound") or 0.0)
    rates = {}  # axis -> {group: observed order}
    if study.refine_axis:
        rates[study.refine_axis] = convergence_rates(study, records, floor)
    if study.step_axis:  # at the finest mesh only: on coarser ones the mesh error hides the step's
        finest = finest_mesh(study, records)
        rates[study.step_axis] = convergence_rates(study, finest, floor, study.step_axis, shrinks=True)
    cols = write_csv(out / "results.csv", study, records)
    figures = write_plots(out, study, records, target, rates) if any(_ok(r) for r in records) else []
    best = cheapest(records, target)
    if best:
        answer = (f"cheapest setting reaching {study.error_name} <= {target:g}: {setting_text(study, best)} "
                  f"(error {best['error']:.3g}, {best['wall_s']:.3g} s)")
        # timings a few percent apart are machine noise: say what else costs about the same
        ties = [r for r in records if _ok(r) and r is not best and r["error"] <= target
                and r["wall_s"] <= (1 + TIE) * best["wall_s"]]
        if ties:
            acc = min(ties, key=lambda r: r["error"])
            answer += (f"; {len(ties)} other setting(s) reach it within {TIE:.0%} of that time (a tie on this "
                       f"machine), the most accurate of them {setting_text(study, acc)} (error {acc['error']:.3g}, "
                       f"{acc['wall_s']:.3g} s)")
    else:
        good = [r for r in records if _ok(r)]
        closest = min(good, key=lambda r: r["error"]) if good else None
        answer = (f"no setting reached {study.error_name} <= {target:g}" +
                  (f"; the smallest error was {closest['error']:.3g} with {setting_text(study, closest)} "
                   f"({closest['wall_s']:.3g} s)" if closest else ""))
    if best and floor and best["error"] < floor:
        answer += f" (an error below the reference's own, {floor:.2g}: at the reference's accuracy)"
    ranked = [r["error"] for r in records if _ok(r) and r["error"] >= floor]
    worth = (f" The smallest error ranked above it is {min(ranked) / floor:.3g}x the reference's error bound"
             f" ({'at least' if min(ranked) >= 10 * floor else 'less than'} the 10x a ranking needs)."
             if floor and ranked else "")
    front = pareto_front(records)
    lines = [f"# {study.title}", "", study.notes.strip(), "",
             f"Reference: {reference.get('how', '?')}" +
             (f" (its own error is below {floor:.2g})" if floor else "") + "." + worth, "",
             f"Error: {study.error_name}. Time: {meta['timing']}. Variant `{meta['variant']}`, "
             f"{len(records)} of {planned} settings finished, {meta['jobs']} worker process(es) on {meta['cores']} "
             f"core(s) ({meta['date']}; parallel workers on a shared machine inflate times: use `--jobs 1` for "
             "clean timings). Reproduce: `" + meta["command"] + "`.", "",
             "| " + " | ".join(cols) + " | Pareto |", "|" + "---|" * (len(cols) + 1)]
    front_ids = {id(r) for r in front}
    def cell(r, c):  # an error below the reference's own is not a measured error: say so
        if c == "error" and floor and _ok(r) and r["error"] < floor:
            return f"{_fmt(r['error'])} (at the reference's accuracy)"
        return _fmt(r.get(c))

    for r in records:
        lines.append("| " + " | ".join(cell(r, c) for c in cols) + f" | {'*' if id(r) in front_ids else ''} |")
    for axis, axis_rates in rates.items():
        if not axis_rates:  # nothing above the reference's error floor: no rate to state
            continue
        where = (f" at the finest {study.refine_axis}" if axis == study.step_axis and study.refine_axis else "")
        lines += ["", f"Observed convergence rate in {axis}{where} (three finest points above 3x the reference error; "
                      f"error ~ {axis}^{'p' if axis == study.step_axis else '-p'}):", "", "| setting | rate p |",
                  "|---|---|"]
        lines += [f"| {g} | {_fmt(v)} |" for g, v in sorted(axis_rates.items())]
    if figures:
        lines += [""] + [f"![{f}]({f})" for f in figures]
    lines += ["", "## Answer", "", f"- {answer}."]
    if study.conclusions:
        lines += [f"- {c}" for c in study.conclusions(records, reference)]
    (out / "report.md").write_text("\n".join(lines) + "\n")
    return answer
