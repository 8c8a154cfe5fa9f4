"""A study's report: results.csv, report.md (table, convergence rates, the cheapest setting reaching the target)
and the figures: error vs wall time (log-log; the Pareto front, the target, the answer and the reference's own error
marked) and error vs the refinement axis with the observed convergence rate."""
from __future__ import annotations

import csv
import math
import textwrap
from pathlib import Path

import numpy as np

from ancf_sym.study.base import Study


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


def encodings(study: Study) -> dict[str, str]:
    """Which axis each visual channel of error_vs_time.png shows: colour = the first categorical axis (integrator,
    strain, method, element), marker = the refinement axis (n), then marker size and fill for the axes left (a study
    with more axes folds the rest into the colour's label)."""
    names = [a.name for a in study.axes]
    colour = next((a.name for a in study.axes if a.kind is str and a.name != study.refine_axis), None)
    marker = study.refine_axis if study.refine_axis in names else None
    rest = [n for n in names if n not in (colour, marker)]
    if colour is None and rest:
        colour = rest.pop(0)
    if marker is None and rest:
        marker = rest.pop(0)
    out = {"colour": colour, "marker": marker}
    for channel in ("size", "fill"):
        if rest:
            out[channel] = rest.pop(0)
    out["colour_extra"] = rest  # shown in the colour legend's labels
    return {k: v for k, v in out.items() if v is not None}


MARKERS = "osD^v<>phX*"
SIZES = (5, 7, 9, 11, 13, 15)
FILLS = ("full", "none", "left", "bottom")


def _values(study: Study, axis: str, records: list[dict]) -> list:
    """The axis' values present in the records, in the study's declared order."""
    present = {r[axis] for r in records}
    declared = [v for v in study.axis(axis).values if v in present]
    return declared + sorted(present - set(declared), key=str)


def _legend(ax, handles: list, title: str, y: float):
    """A legend outside the axes on the right, its top at height y (axes fraction); returns it (kept on the axes)."""
    leg = ax.legend(handles=handles, title=title, loc="upper left", bbox_to_anchor=(1.02, y), fontsize=7,
                    title_fontsize=8, frameon=False, borderaxespad=0.0)
    ax.add_artist(leg)
    return leg


def write_plots(out: Path, study: Study, records: list[dict], target: float, rates: dict, floor: float = 0.0,
                answer: dict | None = None) -> list[str]:
    """error_vs_time.png (each setting; colour, marker, size and fill per axis, one legend per meaning outside the
    axes; the reference's own error as a grey band, the Pareto front, the target and the answer marked) and one
    convergence figure per axis in `rates`."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch
    from matplotlib.ticker import NullFormatter, ScalarFormatter

    ok = [r for r in records if _ok(r) and r["error"] > 0]
    files = []
    enc = encodings(study)
    cax, extra = enc["colour"], enc["colour_extra"]

    def colour_key(r):
        return (r[cax], *(r[a] for a in extra))
    ckeys = sorted({colour_key(r) for r in ok}, key=lambda k: (_values(study, cax, ok).index(k[0]), [str(v) for v in
                                                                                                   k[1:]]))
    colors = {k: plt.cm.tab10(i % 10) for i, k in enumerate(ckeys)}
    chan = {c: (enc[c], _values(study, enc[c], ok)) for c in ("marker", "size", "fill") if c in enc}
    style = {"marker": MARKERS, "size": SIZES, "fill": FILLS}

    def pick(channel, r, default):
        if channel not in chan:
            return default
        axis, vals = chan[channel]
        if channel == "size" and len(vals) == 1:
            return 7
        return style[channel][vals.index(r[axis]) % len(style[channel])]
    fig, ax = plt.subplots(figsize=(7.5, 5.2))
    errs = [r["error"] for r in ok]
    lo = min(errs + ([floor] if floor > 0 else [])) / 2
    hi = max(errs + [target]) * 2
    if floor > 0:
        ax.axhspan(lo, floor, color="0.88", zorder=0, lw=0)
    for r in ok:
        c = colors[colour_key(r)]
        fill = pick("fill", r, "full")
        ax.loglog(r["wall_s"], r["error"], pick("marker", r, "o"), ms=pick("size", r, 6), color=c, fillstyle=fill,
                  markerfacecoloralt="white" if fill not in ("full", "none") else "none", mec=c, alpha=0.85, zorder=3)
    front = [r for r in pareto_front(records) if r["error"] > 0]
    if front:
        ax.loglog([r["wall_s"] for r in front], [r["error"] for r in front], "k-", lw=1.2, drawstyle="steps-post",
                  zorder=2)
    ax.axhline(target, color="0.3", ls="--", lw=1)
    if answer is not None and _ok(answer) and answer["error"] > 0:
        ax.loglog(answer["wall_s"], answer["error"], "o", ms=18, mfc="none", mec="k", mew=1.6, zorder=4)
        ax.annotate("answer", (answer["wall_s"], answer["error"]), xytext=(12, -14), textcoords="offset points",
                    fontsize=8, zorder=4)
    ax.set_ylim(lo, hi)
    ax.set_xlabel(study.extra.get("time_label", "wall time per setting [s]"))
    ax.set_ylabel(study.error_name)
    ax.set_title(textwrap.fill(f"{study.title}: error vs time", 70), fontsize=10)
    ax.grid(alpha=0.3, which="both")
    # legends, one per meaning, stacked outside the axes on the right
    y = 1.0
    heads = [Line2D([], [], ls="", marker="s", ms=7, color=colors[k], label=", ".join(map(str, k))) for k in ckeys]
    legs = [(heads, ", ".join([cax, *extra]))]
    for channel in ("marker", "size", "fill"):
        if channel in chan:
            axis, vals = chan[channel]
            hs = [Line2D([], [], ls="", color="0.35", marker=style["marker"][i % len(MARKERS)] if channel == "marker"
                         else "o", ms=(style["size"][i % len(SIZES)] if len(vals) > 1 else 7) if channel == "size"
                         else 6,
                         fillstyle=style["fill"][i % len(FILLS)] if channel == "fill" else "full",
                         markerfacecoloralt="white", label=str(v)) for i, v in enumerate(vals)]
            legs.append((hs, axis))
    marks = [Line2D([], [], color="k", lw=1.2, label="Pareto front"),
             Line2D([], [], color="0.3", ls="--", lw=1, label=f"target {target:g}")]
    if answer is not None and _ok(answer):
        marks.append(Line2D([], [], ls="", marker="o", ms=11, mfc="none", mec="k", mew=1.6, label="answer"))
    if floor > 0:
        marks.append(Patch(color="0.88", label=f"reference's own error (< {floor:.2g})"))
    legs.append((marks, ""))
    fig.tight_layout()
    placed = []
    for hs, title in legs:
        placed.append(_legend(ax, hs, title, y))
        fig.canvas.draw()
        y = placed[-1].get_window_extent().transformed(ax.transAxes.inverted()).y0 - 0.04
    # the saved figure grows to hold the legends
    fig.savefig(out / "error_vs_time.png", dpi=120, bbox_inches="tight", bbox_extra_artists=placed)
    plt.close(fig)
    files.append("error_vs_time.png")
    for axis, axis_rates in rates.items():
        fig, ax = plt.subplots(figsize=(7.5, 5.2))
        sub = sorted(axis_rates) if axis == study.step_axis else sorted({group_label(study, r, axis) for r in ok})
        if not sub:
            plt.close(fig)
            continue
        for i, g in enumerate(sub):
            pts = sorted((float(r[axis]), r["error"]) for r in ok if group_label(study, r, axis) == g)
            rate = axis_rates.get(g)
            lab = g + (f" (rate {rate:.2f})" if rate is not None else "")
            ax.loglog([p[0] for p in pts], [p[1] for p in pts], MARKERS[i % len(MARKERS)] + "-",
                      color=plt.cm.tab10(i % 10), label=lab, ms=4, lw=1)
        ax.axhline(target, color="0.3", ls="--", lw=1, label=f"target {target:g}")
        errs = [r["error"] for r in ok]
        lo = min(errs + ([floor] if floor > 0 else [])) / 2
        if floor > 0:
            ax.axhspan(lo, floor, color="0.88", zorder=0, lw=0, label=f"reference's own error (< {floor:.2g})")
        ax.set_ylim(lo, max(errs + [target]) * 2)
        ticks = sorted({float(r[axis]) for r in ok})
        ax.set_xticks(ticks)
        ax.xaxis.set_major_formatter(ScalarFormatter())
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel(axis)
        ax.set_ylabel(study.error_name)
        ax.set_title(textwrap.fill(f"{study.title}: convergence in {axis}", 70), fontsize=10)
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), frameon=False, borderaxespad=0.0)
        fig.tight_layout()
        fig.savefig(out / f"error_vs_{axis}.png", dpi=120, bbox_inches="tight")
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
    best = cheapest(records, target)
    figures = write_plots(out, study, records, target, rates, floor, best) if any(_ok(r) for r in records) else []
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
             f"Target: {study.error_name} <= {target:g} (" + ("as given" if meta.get("target_given") else
                                                              "the study's default") + ").", "",
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
