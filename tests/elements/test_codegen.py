"""The committed C in generated/ is what the current symbolic code generates (the drift test: docs/kernels.md), and the
check notices a changed file and names it.

Runs `python -m ancf_sym.codegen --check` in a subprocess with the project root as working directory, so the
symbolic source is the working tree's (not the installed copy the other tests use). About 1 s per run.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def run_check(*extra: str) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONSAFEPATH")}
    code = ("import sys, ancf_sym; from pathlib import Path; "
            f"assert Path(ancf_sym.__file__).resolve().parent == Path({str(ROOT / 'ancf_sym')!r}), ancf_sym.__file__; "
            "from ancf_sym.codegen.__main__ import main; sys.exit(main(sys.argv[1:]))")
    # same as `python -m ancf_sym.codegen --check ...` from the root, plus the assertion that the tree is used
    return subprocess.run([sys.executable, "-c", code, "--check", *extra], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=300)


def test_generated_is_in_sync_with_symbolic_source():
    r = subprocess.run([sys.executable, "-m", "ancf_sym.codegen", "--check"], cwd=ROOT, capture_output=True,
                       text=True, timeout=300,
                       env={k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONSAFEPATH")})
    assert r.returncode == 0, f"generated/ is stale (run `python -m ancf_sym.codegen`):\n{r.stdout}\n{r.stderr}"
    assert "up to date" in r.stdout


def test_check_names_an_altered_kernel(tmp_path):
    copy = tmp_path / "generated"
    shutil.copytree(ROOT / "generated", copy)
    target = copy / "cable3d_bending.c"
    text = target.read_text()
    assert "cable3d_bending" in text
    target.write_text(text.replace("casadi_real", "double", 1) + "\n/* edited by hand */\n")
    r = run_check("--out", str(copy))
    assert r.returncode != 0
    stale = [line.strip() for line in r.stderr.splitlines() if line.startswith("  ")]
    assert stale == ["cable3d_bending.c"], r.stderr  # only the altered file: the rest of the copy is in sync

    target.unlink()  # a missing file is stale too
    r = run_check("--out", str(copy))
    assert r.returncode != 0 and "cable3d_bending.c" in r.stderr
