"""Every ```python block of README.md and docs/*.md runs as written: alone, in a fresh Python process, in an empty
temporary folder (with `examples/` of the project beside it, since the pages name bundled files by that path), with
every warning an error.

A block that cannot run alone (a fragment of a larger scene, a call that needs a cluster) says so in its first
line, visibly, with the reason: `# sketch, not run: <why>`. Such blocks are few and each names where the same
calls do run. The outcome of each block is exact (it ran or raised), so there is no tolerance to justify.
"""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PAGES = [ROOT / "README.md"] + sorted((ROOT / "docs").glob("*.md"))
BLOCK = re.compile(r"^```python\n(.*?)^```", re.S | re.M)
SKETCH = re.compile(r"#\s*sketch, not run:\s*(\S.{10,})")  # the marker and a reason of a few words at least


def blocks() -> list[tuple[str, int, str]]:
    """(page, first line of the block, code) for every python block."""
    out = []
    for page in PAGES:
        text = page.read_text(encoding="utf-8")
        for m in BLOCK.finditer(text):
            out.append((page.relative_to(ROOT).as_posix(), text[:m.start()].count("\n") + 2, m.group(1)))
    return out


BLOCKS = blocks()


def test_the_pages_have_blocks_and_few_sketches():
    """The README's tour is all runnable; sketches stay the exception (under a third of the blocks)."""
    readme = [b for b in BLOCKS if b[0] == "README.md"]
    assert len(readme) >= 4
    assert not [b for b in readme if SKETCH.match(b[2])], "the README's blocks all run"
    sketches = [b for b in BLOCKS if SKETCH.match(b[2])]
    assert 3 * len(sketches) < len(BLOCKS), [f"{p}:{n}" for p, n, _ in sketches]


# Warnings between two libraries, none of this package's doing, are let through: matplotlib < 3.9 calls pyparsing's
# old names (parseString, resetCache, ...), which pyparsing >= 3.3 deprecates, and trips its diagnostics (seen with
# matplotlib 3.8, the oldest numpy's partner): warnings raised inside matplotlib or pyparsing are let through, every
# other warning stays an error
THIRD_PARTY = ("import warnings; warnings.filterwarnings('ignore', module=r'(matplotlib|pyparsing)(\\.|$)')\n")


@pytest.mark.parametrize("page,line,code", BLOCKS, ids=[f"{p}:{n}" for p, n, _ in BLOCKS])
def test_block_runs_as_written(page: str, line: int, code: str, tmp_path: Path):
    first = code.lstrip().splitlines()[0] if code.strip() else ""
    if first.lstrip().startswith("#") and "sketch" in first:
        m = SKETCH.match(first.strip())
        assert m, f"{page}:{line}: a sketch marker must read '# sketch, not run: <reason>', got {first!r}"
        pytest.skip(f"{page}:{line}: {m.group(1)}")
    (tmp_path / "examples").symlink_to(ROOT / "examples")
    env = dict(os.environ, MPLBACKEND="Agg", PYTHONWARNINGS="error")
    env.pop("PYTHONPATH", None)
    # -W error: a warning (e.g. CasADi's FutureWarning on NumPy arithmetic with DMs) fails the block; -I would drop
    # the venv's site-packages, so the folder alone keeps the source tree off sys.path
    proc = subprocess.run([sys.executable, "-W", "error", "-c", THIRD_PARTY + code], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, f"{page}:{line} failed:\n{code}\n--- stderr:\n{proc.stderr[-3000:]}"
    assert "Warning" not in proc.stderr, f"{page}:{line} warned:\n{proc.stderr[-3000:]}"
