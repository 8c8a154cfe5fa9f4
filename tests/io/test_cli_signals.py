"""A run survives signals and an --out it cannot replace: Ctrl-C (SIGINT) and SIGTERM stop any run promptly with
exit 130 / 143, one line and no traceback, the previous result intact and nothing temporary left; temporary
directories of a killed run are removed by the next run; finished results that cannot replace --out are kept and
their place is named.

The CLI runs in a subprocess whose stderr is a pseudo-terminal, so that its progress display shows the stage it is
in: the tests wait for the stage to appear (IPOPT iterating, time stepping) instead of sleeping a fixed time, so a
slow or loaded machine only makes them slower."""
from __future__ import annotations

import fcntl
import json
import os
import pty
import select
import signal
import struct
import subprocess
import sys
import termios
import time
from pathlib import Path

import pytest

from ancf_sym import cli

ROOT = Path(__file__).resolve().parents[2]
CATENARY = ROOT / "examples" / "scenes" / "catenary.toml"

# a clamped 3D rubber rope of 6000 elements under a large end force: IPOPT needs hundreds of iterations on ~72000
# coordinates (about a minute), so a signal sent once IPOPT reports its first attempt arrives while it iterates even
# on a loaded machine (at 1500 elements the faster statics engine finished within a second, before the signal)
SLOW_STATICS = """
[scene]
name = "slow"
dim = 3
gravity = [0.0, 0.0, -9.81]
[materials.rubber]
E = 5e6
density = 1100.0
[sections.rope]
shape = "circle"
diameter = 0.01
[[members]]
name = "rope"
points = [[0.0, 0.0, 0.0], [10.0, 0.0, 0.0]]
elements = 6000
material = "rubber"
section = "rope"
[[supports]]
type = "clamp"
member = "rope"
at = "start"
[[loads]]
type = "force"
member = "rope"
at = "end"
value = [0.0, 30.0, 50.0]
[analysis]
type = "statics"
max_iter = 3000
"""

# paper 000's pendulum integrated for 1000 s at dt = 1 ms: a million steps, far longer than any test waits
SLOW_DYNAMICS = (ROOT / "examples" / "scenes" / "pendulum.toml").read_text().replace("t_end = 1.0", "t_end = 1000.0")


def start_and_signal(scene: Path, out: Path, marker: bytes, sig: int) -> tuple[int, str, float]:
    """Run `ancf-sym run scene --out out` with stderr on a pty; once `marker` shows in the progress display, send
    sig; (exit code, stderr text, seconds from the signal to the exit)."""
    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 200, 0, 0))  # a width, or the bar is empty
    p = subprocess.Popen([sys.executable, "-m", "ancf_sym.cli", "run", str(scene), "--out", str(out)],
                         cwd=out.parent, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=slave)
    os.close(slave)
    buf = b""

    def read(timeout):
        nonlocal buf
        r, _, _ = select.select([master], [], [], timeout)
        if r:
            try:
                buf += os.read(master, 65536)
            except OSError:  # the child closed the pty
                return False
        return True

    try:
        deadline = time.monotonic() + 600
        while marker not in buf:
            assert p.poll() is None, f"the run ended before {marker!r} showed: {buf[-2000:]!r}"
            assert time.monotonic() < deadline, f"{marker!r} never showed: {buf[-2000:]!r}"
            read(0.2)
        t0 = time.monotonic()
        p.send_signal(sig)
        while p.poll() is None:
            read(0.2)
        while read(0.1) and select.select([master], [], [], 0)[0]:
            pass
        return p.returncode, buf.decode(errors="replace"), time.monotonic() - t0
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
        os.close(master)


def previous_result(tmp_path: Path) -> tuple[Path, dict]:
    out = tmp_path / "out"
    r = subprocess.run([sys.executable, "-m", "ancf_sym.cli", "run", str(CATENARY), "--out", str(out), "--quiet"],
                       cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    return out, {p.name: p.read_bytes() for p in out.iterdir()}


def last_line(text: str) -> str:
    """The text after the progress display's last redraw (carriage returns and clear-line escapes)."""
    lines = [ln.strip() for ln in text.replace("\x1b[A", "").replace("\r", "\n").split("\n")]
    return [ln for ln in lines if ln][-1]


@pytest.mark.parametrize("sig, code, word", [(signal.SIGINT, 130, "interrupted"), (signal.SIGTERM, 143, "terminated")])
def test_signal_during_ipopt_stops_the_run_and_keeps_the_previous_result(tmp_path, sig, code, word):
    """IPOPT (through CasADi) swallows the KeyboardInterrupt and returns a failed status; the statics engine would
    then start its next attempt and replace --out. The run must stop instead: well before the solve's seconds are
    up (30 s is generous on any machine for unwinding after one IPOPT iteration of ~0.1 s), with the shell's exit
    code 128 + signal."""
    out, before = previous_result(tmp_path)
    scene = tmp_path / "slow.toml"
    scene.write_text(SLOW_STATICS)
    rc, err, after = start_and_signal(scene, out, b"IPOPT full steps ...", sig)
    assert rc == code, err[-3000:]
    assert "Traceback" not in err and "KeyboardInterrupt" not in err and err.count("ancf-sym:") == 1, err[-3000:]
    assert "CasADi - " not in err, err[-3000:]  # its warning about the caught interrupt is not a second report
    line = last_line(err)
    assert line.startswith("ancf-sym: slow: ") and word in line and f"previous results in {out} kept" in line, line
    assert after < 30, f"took {after:.1f} s to stop"
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before, "previous result changed"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out", "slow.toml"], "temporary or failed dirs left"


def test_ctrl_c_during_dynamics_exits_130_without_traceback(tmp_path):
    out, before = previous_result(tmp_path)
    scene = tmp_path / "long.toml"
    scene.write_text(SLOW_DYNAMICS)
    rc, err, after = start_and_signal(scene, out, b"t = ", signal.SIGINT)
    assert rc == 130 and "Traceback" not in err, err[-3000:]
    assert "interrupted (Ctrl-C)" in last_line(err), err[-3000:]
    assert after < 30
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["long.toml", "out"]


def test_leftovers_of_a_killed_run_are_removed_by_the_next(tmp_path):
    """A run killed outright (SIGKILL) cannot clean up: its `.out.<pid>.*.tmp` stays. The next run into the same
    --out removes those whose process is gone and leaves a live run's alone."""
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    stale = tmp_path / f".out.{dead.pid}.x1.tmp"
    live = tmp_path / f".out.{os.getpid()}.x2.tmp"  # this test's own process: alive
    old = tmp_path / f".out.old-{dead.pid}"
    for d in (stale, live, old):
        d.mkdir()
        (d / "result.json").write_text("{}")
    out, _ = previous_result(tmp_path)
    assert not stale.exists() and not old.exists() and live.is_dir()


def test_unreplaceable_out_keeps_the_finished_results_and_names_them(tmp_path, monkeypatch, capsys):
    """When the old --out (or its .failed twin) cannot be moved aside (permissions, an immutable folder: simulated
    by a rename that raises PermissionError), the finished results are not thrown away: they stay in a visible
    sibling that the message names; --out is untouched; exit 1."""
    out, before = previous_result(tmp_path)
    real_rename = os.rename

    def rename(src, dst):
        if Path(src) in (out, out.with_name("out.failed")):
            raise PermissionError(1, "Operation not permitted")
        return real_rename(src, dst)
    monkeypatch.setattr(os, "rename", rename)
    monkeypatch.chdir(tmp_path)
    assert cli.main(["run", str(CATENARY), "--out", str(out), "--quiet"]) == 1
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and f"cannot replace {out}" in err and "PermissionError" in err, err
    kept = Path(err.rsplit("this run's results are in ", 1)[1])
    assert kept.parent == tmp_path and kept.name.startswith("out.") and not kept.name.startswith(".")
    assert json.loads((kept / "result.json").read_text())["success"] is True
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert not list(tmp_path.glob(".out*")), "temporary directories left behind"
