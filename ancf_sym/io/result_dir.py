"""A run's output directory, replaced only by a finished run.

Everything is written into a hidden sibling `.DIR.<pid>.<random>.tmp` first. `commit` renames it to DIR (success)
or to DIR.failed (failure); an interrupted run (Ctrl-C, SIGTERM, an exception) removes it on the way out, and one
killed outright (SIGKILL, power loss) leaves it behind for the next run into the same DIR to remove (its process is
gone). If DIR or DIR.failed cannot be replaced (permissions, an immutable folder), the finished results are kept in
a visible sibling and the caller is told where.
"""
from __future__ import annotations

import contextlib
import os
import shutil
import signal
import tempfile
import time
from pathlib import Path
from typing import Iterator

from ancf_sym.util.checks import SceneError

RESULT_FILE = "result.json"


def check_out(path: Path) -> None:
    """Refuse to replace anything that is not a previous result directory of this tool."""
    if path.exists() and not path.is_dir():
        raise SceneError(f"--out {path}: exists and is not a directory")
    if path.is_dir() and any(path.iterdir()) and not (path / RESULT_FILE).is_file():
        raise SceneError(f"--out {path}: exists, is not empty and holds no {RESULT_FILE}: "
                         "not replacing it; choose another directory")


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # someone else's live process
        return True
    return True


def remove_stale(out: Path) -> list[Path]:
    """Remove the temporary siblings of out and out.failed whose run is gone (its pid, in the name, is not
    running); a concurrent run's are left alone. Returns what was removed."""
    removed = []
    for name in (out.name, out.name + ".failed"):
        for p in out.parent.glob(f".{name}.*"):
            rest = p.name[len(name) + 2:]  # "<pid>.<random>.tmp" or "old-<pid>"
            if rest.endswith(".tmp"):
                pid = rest.split(".", 1)[0]
            elif rest.startswith("old-"):
                pid = rest[4:]
            else:
                continue
            if pid.isdigit() and not _alive(int(pid)):
                shutil.rmtree(p, ignore_errors=True)
                removed.append(p)
    return removed


@contextlib.contextmanager
def _signals_held() -> Iterator[None]:
    """Ctrl-C / SIGTERM wait until the renames are done (a directory is never left half-swapped)."""
    sigs = {signal.SIGINT, signal.SIGTERM}
    old = signal.pthread_sigmask(signal.SIG_BLOCK, sigs)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def replace_dir(src: Path, dst: Path) -> None:
    """Put the finished directory src in place of dst (renames on one filesystem: dst is never half-written)."""
    with _signals_held():
        if not dst.exists():
            os.rename(src, dst)
            return
        old = dst.with_name(f".{dst.name}.old-{os.getpid()}")
        os.rename(dst, old)
        try:
            os.rename(src, dst)
        except OSError:
            os.rename(old, dst)
            raise
    shutil.rmtree(old, ignore_errors=True)


class ResultDir:
    """`with ResultDir(out) as rd:` write into rd.tmp, then `rd.commit(ok)`; the temporary directory never
    outlives the block unless it holds finished results that could not be put in place (then commit says where)."""

    def __init__(self, out: Path):
        self.out = Path(out).absolute()
        self.failed = self.out.with_name(self.out.name + ".failed")
        check_out(self.out)
        check_out(self.failed)
        self.tmp: Path | None = None

    def __enter__(self) -> "ResultDir":
        try:
            self.out.parent.mkdir(parents=True, exist_ok=True)
            remove_stale(self.out)
            tmp = Path(tempfile.mkdtemp(prefix=f".{self.out.name}.{os.getpid()}.", suffix=".tmp",
                                        dir=self.out.parent))
        except OSError as exc:
            raise SceneError(f"--out {self.out}: cannot create a directory beside it: {exc}") from None
        umask = os.umask(0)
        os.umask(umask)
        tmp.chmod(0o777 & ~umask)  # mkdtemp makes it private; the result directory gets the usual permissions
        self.tmp = tmp
        return self

    def commit(self, ok: bool) -> tuple[Path, str | None]:
        """Move the results to out (ok) or out.failed; (where they are, None) or, if that directory could not be
        replaced, (a visible sibling holding them, the reason)."""
        dst = self.out if ok else self.failed
        try:
            replace_dir(self.tmp, dst)
            self.tmp = None
            return dst, None
        except OSError as exc:
            reason = f"cannot replace {dst} ({type(exc).__name__}: {exc.strerror or exc})"
        kept = dst.with_name(f"{dst.name}.{time.strftime('%Y%m%d-%H%M%S')}-{os.getpid()}")
        try:
            os.rename(self.tmp, kept)
        except OSError:
            kept = self.tmp  # stays hidden but is named, and not removed on exit
        self.tmp = None
        return kept, reason

    def __exit__(self, *exc) -> None:
        if self.tmp is not None:
            shutil.rmtree(self.tmp, ignore_errors=True)
            self.tmp = None
