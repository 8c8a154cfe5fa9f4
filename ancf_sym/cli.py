"""Command line.

    ancf-sym run SCENE.toml --out DIR [--quiet] [--samples N] [--no-animation] [--sensitivity PATH ...]
                                                                solve the scene's [analysis], write DIR/
    ancf-sym calibrate SCENE.toml DATA.csv --parameter PATH [...] --out DIR
                                                                fit scene numbers to measured node positions
                                                                or natural frequencies
    ancf-sym kernels [--json]                                   the compiled kernel catalogue
    ancf-sym study NAME --out DIR [--quick] [--jobs N | --scheduler ADDRESS] [--sweep AXIS=V1,V2 ...] [--target E]
                                                                what accuracy costs in time (ancf_sym.study)
    ancf-sym study --list                                       the studies
    ancf-sym --version

`run` writes DIR/result.json, DIR/shape.png, DIR/fields.png, DIR/result.vtu and a copy of the scene as
DIR/scene.toml (dynamics: DIR/history.png, DIR/series.pvd with DIR/frames/, and DIR/motion.gif unless
--no-animation; a modal analysis: result.json with the equilibrium and the modes, modes.png, modes.vtu, and
modes.gif unless --no-animation). Everything is written into a temporary sibling directory first
(ancf_sym.io.result_dir); DIR is
replaced only when the solve succeeded, so a failed run never overwrites a previous good DIR: its status goes to
DIR.failed/ instead. Exit codes: 0 success, 1 the solve failed (or an unexpected error, traceback in
DIR.failed/traceback.txt; or finished results that could not replace DIR, kept beside it), 2 bad input (the scene's
SceneError message, naming the TOML field; or an --out that is not a result directory), 130 Ctrl-C, 143 SIGTERM
(stopped at once, nothing written, DIR as it was).
Also runnable as `python -m ancf_sym.cli`.
"""
from __future__ import annotations

import os
import signal
import sys


def _exit_while_loading(signum: int, frame) -> None:
    """Ctrl-C while this module's imports load (nothing started, nothing to clean up): one line, the shell's code.
    From main() on, the commands' own handling takes over."""
    os.write(2, b"ancf-sym: interrupted (Ctrl-C)\n")
    os._exit(128 + signum)


_HANDLER = signal.getsignal(signal.SIGINT)
if _HANDLER is signal.default_int_handler:  # (an ignored SIGINT, e.g. a background job, stays ignored)
    try:
        signal.signal(signal.SIGINT, _exit_while_loading)
    except ValueError:  # imported outside the main thread: signals are not ours to handle
        pass

import argparse  # noqa: E402 - after the handler above
import copy  # noqa: E402
import shutil  # noqa: E402
import time  # noqa: E402
import traceback  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import TYPE_CHECKING  # noqa: E402

from ancf_sym.util.checks import SceneError  # noqa: E402 - (the package itself imports nothing until used)
from ancf_sym.util.interrupts import Terminated, terminate_raises  # noqa: E402
from ancf_sym.io.result_dir import RESULT_FILE, ResultDir  # noqa: E402

if TYPE_CHECKING:
    from ancf_sym.scene.builder import Scene


class Progress:
    """A tqdm bar over the stages of a run (stderr); `note` shows what the current stage is doing."""

    def __init__(self, stages: list[str], quiet: bool):
        from ancf_sym.util.interrupts import progress_bar as tqdm
        self.bar = tqdm(total=len(stages), disable=True if quiet else None,  # None: only on a terminal
                        leave=False, dynamic_ncols=True,
                        bar_format="{desc}{postfix}  [{n_fmt}/{total_fmt} stages done, {elapsed}]")
        self.started = False

    def stage(self, name: str) -> None:
        self.bar.set_description_str(name, refresh=False)
        self.bar.set_postfix_str("", refresh=False)
        self.bar.update(1 if self.started else 0)
        self.bar.refresh()
        self.started = True

    def note(self, text: str) -> None:
        self.bar.set_postfix_str(text)

    def close(self) -> None:
        """Idempotent: safe to call again."""
        if self.started:
            self.started = False
            self.bar.update(1)
        self.bar.close()


# -- analyses ----------------------------------------------------------------------------------------------------

STATICS_STAGES = ["read scene", "assemble", "build solver", "solve", "write result.json", "plots", "VTK"]


def run_statics(scene: Scene, analysis: dict, scene_file: Path, out: Path, progress: Progress, t_start: float,
                samples: int | None, animation: bool = True) -> tuple[bool, str]:
    """Solve and write the outputs into `out`; (success, one-line summary)."""
    from ancf_sym.model.assembly import Assembly
    from ancf_sym.io.json_out import static_result_dict, write_json
    from ancf_sym.statics.problem import StaticProblem

    progress.stage("assemble")
    asm = Assembly(scene)
    progress.note(f"{asm.n} coordinates, {len(asm.terms)} kernel terms")
    progress.stage("build solver")
    problem = StaticProblem(asm, progress=progress.note)  # shows each IPOPT attempt as it runs
    progress.stage("solve")
    r = problem.solve(analysis.options)  # (decoded once, by the TOML reader)
    wall_total = time.perf_counter() - t_start
    progress.stage("write result.json")
    write_json(out / RESULT_FILE, static_result_dict(r, scene_file, analysis, wall_total), clean=False)
    if r.success:
        from ancf_sym.io.plots import write_plots
        from ancf_sym.io.vtk import DEFAULT_SAMPLES, samples_per_element, write_vtu
        progress.stage("plots")
        write_plots(r, out, samples or DEFAULT_SAMPLES)
        progress.stage("VTK")
        write_vtu(r, out / "result.vtu", samples_per_element(asm.mesh, samples))
    # who answered, in its own words (Newton's "converged", IPOPT's return code): result.json's solver.solved_by
    summary = (f"{scene.name}: {'solved by ' if r.success else r.status + ': '}{r.solved_by}, "
               f"solve {r.wall_s:.3f} s, total {wall_total:.3f} s")
    if r.success:
        summary += f"; potential {r.potential:.6g} J, constraint violation {r.constraint_violation:.2g}"
    elif r.attempts and r.attempts[-1].get("detail"):  # why it is not a solution (e.g. a contact the law missed)
        summary += f"; {r.attempts[-1]['detail']}"
    return r.success, summary


DYNAMICS_STAGES = ["read scene", "assemble", "integrate", "write result.json, plots, VTK series, animation"]


def run_dynamics_cli(scene: Scene, analysis: dict, scene_file: Path, out: Path, progress: Progress, t_start: float,
                     samples: int | None, animation: bool = True) -> tuple[bool, str]:
    """Integrate the scene (progress: simulated time) and write result.json, history.png, series.pvd + frames,
    motion.gif (animation)."""
    from ancf_sym.model.assembly import Assembly
    from ancf_sym.dynamics import simulate
    from ancf_sym.io.dynamics_output import write_outputs

    progress.stage("assemble")
    opts = copy.copy(analysis.options)  # (decoded once, by the TOML reader)
    opts.record_states = True  # every coordinate at the output times: the VTK series and the animation
    asm = Assembly(scene)
    progress.stage("integrate")

    def report(t: float, t_end: float) -> None:
        progress.note(f"t = {t:.4g} / {t_end:.4g} s")

    r = simulate(asm, opts, report)
    wall_total = time.perf_counter() - t_start
    progress.stage("write result.json, plots, VTK series, animation")
    write_outputs(r, scene_file, analysis, out, wall_total, samples, animation)
    summary = (f"{scene.name}: {r.status} at t = {r.t_reached:.6g} s, {r.steps} steps, "
               f"{r.newton_iterations} Newton iterations, {len(r.rejected)} rejected; integrate {r.wall_s:.3f} s, "
               f"total {wall_total:.3f} s")
    if not r.success and r.message:
        summary += f"; {r.message}"
    return r.success, summary


MODAL_STAGES = ["read scene", "solve statics, modes", "write result.json, modes.png, modes.vtu"]


def run_modal(scene: Scene, analysis: dict, scene_file: Path, out: Path, progress: Progress, t_start: float,
              samples: int | None, animation: bool = True) -> tuple[bool, str]:
    """The static equilibrium and the lowest modes about it (ancf_sym.modal); result.json, modes.png, modes.vtu."""
    from ancf_sym.modal import modal_analysis
    from ancf_sym.modal.output import animate_modes, modal_result_dict, plot_modes, write_modes_vtu
    from ancf_sym.io.json_out import write_json
    from ancf_sym.io.vtk import DEFAULT_SAMPLES, samples_per_element

    progress.stage("solve statics, modes")
    r = modal_analysis(scene, modes=analysis.get("modes", 10), options=analysis.options,
                       damped=analysis.get("damped", False))
    wall_total = time.perf_counter() - t_start
    progress.stage("write result.json, modes.png, modes.vtu")
    write_json(out / RESULT_FILE, modal_result_dict(r, scene_file, analysis, wall_total))
    if r.success:
        plot_modes(r, out / "modes.png", per_element=samples or DEFAULT_SAMPLES)
        write_modes_vtu(r, out / "modes.vtu", samples_per_element(r.static.assembly.mesh, samples))
        if animation:
            animate_modes(r, out / "modes.gif", per_element=samples or DEFAULT_SAMPLES)
    f = ", ".join(f"{v:.5g}" for v in r.frequencies[:5])
    summary = f"{scene.name}: {r.status}; lowest frequencies [Hz]: {f}; total {wall_total:.3f} s"
    return r.success, summary


# analysis type -> (runner, its progress stages). A runner gets (scene, analysis dict, scene file, output directory
# to fill, Progress, start time, samples per element (None: ancf_sym.io.vtk.samples_per_element), animation
# (dynamics, modal: write a GIF)) and returns (success, one-line summary).
ANALYSES = {"statics": (run_statics, STATICS_STAGES), "dynamics": (run_dynamics_cli, DYNAMICS_STAGES),
            "modal": (run_modal, MODAL_STAGES)}


# -- the run command ---------------------------------------------------------------------------------------------

def _fail(msg: str) -> None:
    print(f"ancf-sym: {msg}", file=sys.stderr)


def cmd_run(args) -> int:
    with terminate_raises():  # SIGTERM unwinds like Ctrl-C: the temporary directory is removed
        return _cmd_run(args)


def _cmd_run(args) -> int:
    from ancf_sym.io.scene_toml import load_scene

    t_start = time.perf_counter()
    scene_file = Path(args.scene)
    try:
        rd = ResultDir(Path(args.out))
        if args.samples is not None and args.samples < 1:
            raise SceneError(f"--samples must be a positive integer, got {args.samples}")
        scene, analysis = load_scene(scene_file)
        if args.sensitivity:  # every path checked before any solving
            from ancf_sym.sensitivity.api import check_paths, read_document
            try:
                check_paths(scene, read_document(scene_file), args.sensitivity, analysis)
            except (KeyError, ValueError) as exc:  # (a path naming nothing, or no differentiable number)
                raise SceneError(str(exc).strip('"')) from None
    except SceneError as exc:
        _fail(str(exc))
        return 2
    if analysis["type"] not in ANALYSES:
        _fail(f"{scene_file}: analysis.type = {analysis['type']!r}: this command runs "
              f"{' | '.join(ANALYSES)} only in this version")
        return 2
    runner, stages = ANALYSES[analysis["type"]]
    try:
        with rd:  # whatever happens (also Ctrl-C, SIGTERM), no temporary directory is left behind
            progress = Progress(stages, args.quiet)
            progress.stage("read scene")
            try:
                return _run_in(rd, scene, analysis, scene_file, runner, progress, t_start, args)
            finally:
                progress.close()
    except SceneError as exc:
        _fail(str(exc))
        return 2
    except (KeyboardInterrupt, Terminated) as exc:
        kept = f"; previous results in {rd.out} kept" if (rd.out / RESULT_FILE).is_file() else ""
        _fail(f"{scene.name}: {_stop_reason(exc)}: stopped, nothing written{kept}")
        return _stop_code(exc)


def _run_in(rd: ResultDir, scene, analysis, scene_file, runner, progress, t_start, args) -> int:
    """Run the analysis writing into rd.tmp; move it to out (success) or to out.failed; the exit code."""
    tmp = rd.tmp
    try:
        shutil.copyfile(scene_file, tmp / "scene.toml")
        ok, summary = runner(scene, analysis, scene_file, tmp, progress, t_start, args.samples,
                             not args.no_animation)
        if ok and args.sensitivity:  # exact derivatives of the results by parameter path (ancf_sym.sensitivity)
            from ancf_sym.sensitivity.api import add_to_result
            add_to_result(tmp / RESULT_FILE, scene, scene_file, analysis, args.sensitivity)
    except SceneError:  # a value only the assembly or solver could refuse
        raise
    except Exception as exc:  # noqa: BLE001 - one line to the user, the traceback into DIR.failed
        progress.close()
        (tmp / "traceback.txt").write_text(traceback.format_exc())
        from ancf_sym.io.json_out import write_json
        write_json(tmp / RESULT_FILE, {"status": "error", "success": False, "error": f"{type(exc).__name__}: {exc}",
                                       "scene": {"name": scene.name, "file": str(scene_file.resolve())}})
        where, problem = rd.commit(False)
        _fail(f"{scene.name}: {type(exc).__name__}: {exc} (details in {where}/traceback.txt"
              + (f"; {problem}" if problem else "") + ")")
        return 1
    progress.close()
    where, problem = rd.commit(ok)
    if problem:  # finished, but the old directory could not be replaced
        _fail(f"{summary}{'' if ok else ' FAILED'}; {problem}: this run's results are in {where}")
        return 1
    if ok:
        if not args.quiet:
            print(f"{summary} -> {where}")
        return 0
    kept = f"previous results in {rd.out} kept; " if (rd.out / RESULT_FILE).is_file() else ""
    _fail(f"{summary} FAILED; {kept}this run's status in {where}")
    return 1


def _stop_reason(exc: BaseException) -> str:
    return "terminated (SIGTERM)" if isinstance(exc, Terminated) else "interrupted (Ctrl-C)"


def _stop_code(exc: BaseException) -> int:
    """The shell's convention: 128 + the signal number."""
    return 128 + (signal.SIGTERM if isinstance(exc, Terminated) else signal.SIGINT)


def cmd_kernels(args) -> int:
    from ancf_sym import kernels
    try:
        cat = kernels.catalogue()
    except FileNotFoundError as exc:
        _fail(str(exc))
        return 1
    if args.json:
        import json
        print(json.dumps(cat, indent=1))
        return 0
    rows = [("name", "element", "effect", "gauss", "q", "p (parameters)")]
    rows += [(k["name"], k["element"], k["effect"], "-" if k["gauss"] is None else str(k["gauss"]),
              str(k["inputs"]["q"]), ", ".join(k["inputs"]["p"])) for k in cat]
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    for j, r in enumerate(rows):
        print("  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip())
        if j == 0:
            print("  ".join("-" * w for w in widths))
    print(f"\n{len(cat)} kernels in {Path(cat[0]['library']).parent if cat else kernels.KERNEL_DIR}")
    return 0


def cmd_study(args) -> int:
    from ancf_sym.study import StudyError, get_study, run_study, studies
    if args.list or not args.name:
        for name, title in studies().items():
            st = get_study(name)
            print(f"{name:20s} {title}\n{'':20s} axes: " +
                  "; ".join(f"{a.name} = {','.join(map(str, a.values))}" for a in st.axes))
        return 0 if args.list else 2
    if not args.out:
        _fail("study: --out DIR is required")
        return 2
    command = "ancf-sym study " + " ".join(sys.argv[2:]) if sys.argv[1:2] == ["study"] else None
    try:
        report = run_study(args.name, args.out, quick=args.quick, jobs=args.jobs, sweep=args.sweep or None,
                           target=args.target, progress=not args.quiet, command=command,
                           scheduler=args.scheduler)
    except StudyError as exc:
        _fail(str(exc))
        return 2
    except KeyboardInterrupt:
        _fail(f"study {args.name}: interrupted (Ctrl-C); finished settings are kept in {args.out} (run again to resume)")
        return 130
    failed = sum(1 for r in report.records if not r.get("success"))
    if not args.quiet:
        print(f"{args.name}: {len(report.records)} settings ({failed} failed) -> {report.out}/report.md\n"
              f"{report.answer}")
    return 0


def cmd_calibrate(args) -> int:
    from ancf_sym.sensitivity.calibrate import run_cli
    try:
        return run_cli(args.scene, args.data, args.parameter, Path(args.out), args.max_iter, args.quiet)
    except (SceneError, KeyError, ValueError) as exc:  # (a bad path, column or value: named in the message)
        _fail(str(exc).strip('"'))
        return 2


def main(argv: list[str] | None = None) -> int:
    """The command line; Ctrl-C or SIGTERM at any moment (also while argparse or a command's imports load) exits
    with one line and the shell's code, never a traceback."""
    try:
        return _main(argv)
    except (KeyboardInterrupt, Terminated) as exc:
        _fail(_stop_reason(exc))
        return _stop_code(exc)


def _main(argv: list[str] | None = None) -> int:
    from ancf_sym import __version__
    parser = argparse.ArgumentParser(prog="ancf-sym", description="ANCF cables and beams: scenes (statics by Newton on "
                                     "the exact tangent, IPOPT where Newton alone fails; modal analysis; dynamics), "
                                     "compiled kernels, studies of accuracy vs time")
    parser.add_argument("--version", action="version", version=f"ancf-sym {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("run", help="solve a TOML scene and write result.json, PNG plots and a .vtu into --out")
    p.add_argument("scene", help="scene file (TOML; see docs/scenes.md)")
    p.add_argument("--out", required=True, help="output directory (replaced only when the run succeeds)")
    p.add_argument("--quiet", action="store_true", help="no progress display, no summary line")
    p.add_argument("--samples", type=int, default=None,
                   help="samples per element in plots and VTK (default 8; fewer on meshes of over 25 000 elements)")
    p.add_argument("--no-animation", action="store_true", help="dynamics: do not write motion.gif")
    p.add_argument("--sensitivity", action="append", default=[], metavar="PATH",
                   help="add the exact derivative of the results (statics, modal; dynamics: the sensors) with respect "
                        "to the scene number at this TOML path (e.g. materials.steel.E) to result.json's "
                        "sensitivities (repeatable)")
    p.set_defaults(func=cmd_run)
    c = sub.add_parser("calibrate", help="fit scene numbers (TOML paths) to measured node positions (CSV: member, "
                       "node, x, y[, z]), natural frequencies (CSV: mode, frequency) or a dynamic sensor history (CSV: t, "
                       "NAME[j], ...) by Levenberg-Marquardt with the exact Jacobian")
    c.add_argument("scene", help="scene file (TOML; its values at the paths are the start)")
    c.add_argument("data", help="CSV of measured positions (member, node, x, y[, z]), frequencies (mode, frequency "
                   "[Hz], mode counted from 0) or a sensor history of the scene's dynamics analysis (t, NAME[j], ...: "
                   "times on the step grid)")
    c.add_argument("--parameter", action="append", required=True, metavar="PATH", help="a TOML path to fit (repeatable)")
    c.add_argument("--out", required=True, help="output directory: calibration.json, calibration.png")
    c.add_argument("--max-iter", type=int, default=30, help="Levenberg-Marquardt iterations at most (default 30)")
    c.add_argument("--quiet", action="store_true", help="no summary line")
    c.set_defaults(func=cmd_calibrate)
    k = sub.add_parser("kernels", help="list the compiled kernels")
    k.add_argument("--json", action="store_true", help="the full catalogue as JSON")
    k.set_defaults(func=cmd_kernels)
    st = sub.add_parser("study", help="sweep settings against a reference: error vs wall time report")
    st.add_argument("name", nargs="?", help="study name (--list shows them)")
    st.add_argument("--out", help="report folder (created; an interrupted study there resumes)")
    st.add_argument("--list", action="store_true", help="list the studies and their axes")
    st.add_argument("--quick", action="store_true", help="the small sweep of the test suite")
    st.add_argument("--jobs", type=int, default=None, help="worker processes (default: the number of cores)")
    st.add_argument("--sweep", action="append", metavar="AXIS=V1,V2", help="replace an axis' values (repeatable)")
    st.add_argument("--target", type=float, default=None, help="error the answer aims at (default: the study's)")
    st.add_argument("--scheduler", default=None, metavar="ADDRESS",
                    help="run the settings on a Dask cluster (a running dask.distributed scheduler, e.g. "
                         "tcp://host:8786; needs pip install 'ancf_sym[cluster]')")
    st.add_argument("--quiet", action="store_true", help="no progress bar, no summary")
    st.set_defaults(func=cmd_study)
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except (KeyboardInterrupt, Terminated) as exc:  # outside a command's own handling (e.g. while importing)
        _fail(_stop_reason(exc))
        return _stop_code(exc)
    except BrokenPipeError:  # e.g. `ancf-sym kernels | head`
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0


if signal.getsignal(signal.SIGINT) is _exit_while_loading:  # loaded: Ctrl-C raises KeyboardInterrupt again
    signal.signal(signal.SIGINT, _HANDLER)

if __name__ == "__main__":
    sys.exit(main())
