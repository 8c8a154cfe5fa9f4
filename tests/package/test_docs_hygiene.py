"""The project's text as a user meets it: the README is a short entry whose commands and links are true and whose
examples table names every example; no tracked file carries a path of one machine, a label of the issue tracker
or a citation of a document the project does not contain.

These are facts about files, so each check is exact (a count, a set, a match): there is no tolerance to justify."""
from __future__ import annotations

import re
import shlex
import subprocess
from functools import lru_cache
from pathlib import Path

import pytest

try:
    import tomllib
except ImportError:  # Python 3.10
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[2]
README = (ROOT / "README.md").read_text(encoding="utf-8")
# written in pieces so that this file does not match itself
MACHINE_PATH = re.compile(r"(?<![\w.$~-])/(?:" + "|".join(["wo" + "rk", "ro" + "ot", "ho" + "me", "tm" + "p"])
                          + r")(?![\w-])")
TRACKER_LABEL = re.compile(r"\b(?:issue|ticket)s?\s*#?\s*\d+\b|\bissues\s+sh" + r"ow\b", re.IGNORECASE)
DESIGN_DOC = "DESI" + "GN.md"


@lru_cache(maxsize=1)
def tracked_text_files() -> tuple[Path, ...]:
    """The files git tracks (else every file outside build products), without binary ones and without the
    generated C (20 MB, written by the code generator whose source is checked here)."""
    try:
        out = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True).stdout
        paths = [ROOT / p for p in out.decode().split("\0") if p]
    except (OSError, subprocess.CalledProcessError):
        skip = {".git", ".venv", "build", "out", "__pycache__"}
        paths = [p for p in ROOT.rglob("*") if p.is_file() and not skip & set(p.relative_to(ROOT).parts)
                 and ".egg-info" not in str(p)]
    texts = []
    for p in paths:
        if not p.is_file() or (p.suffix == ".c" and p.parent.name == "generated"):  # (deleted, not committed)
            continue
        head = p.read_bytes()[:8192]
        if b"\0" not in head:
            texts.append(p)
    return tuple(texts)


def test_readme_is_a_short_entry():
    """<= 180 lines: what the package is, the two commands, a tour, the examples, links (logs live in bench/)."""
    n = len(README.splitlines())
    assert n <= 180, f"README.md has {n} lines"
    first_block = README.index("```")
    assert "ANCF" in README[:first_block], "the README says what the package is before its first command"


def test_readme_first_commands_name_what_exists():
    """The first code block installs, runs a bundled scene through the declared console script, and runs the
    tests: every file it names exists and the script is the one pyproject declares."""
    block = re.search(r"```bash\n(.*?)```", README, re.S).group(1)
    lines = [ln for ln in block.splitlines() if ln.strip()]
    assert len(lines) == 2, lines
    scripts = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]
    words = [w for ln in lines for part in ln.split("&&") for w in shlex.split(part)]
    assert "install" in words and "." in words
    assert any(w.endswith("/ancf-sym") for w in words) and "ancf-sym" in scripts
    assert any(w.endswith("/pytest") for w in words)
    named = [w for w in words if w.endswith((".toml", ".py"))]
    assert named and all((ROOT / w).is_file() for w in named), named


def test_readme_examples_table_names_every_example():
    table = README[README.index("## Examples"):]
    table = table[:table.index("\n## ", 1)]
    rows = {m.group(1) for m in re.finditer(r"^\| `([\w/]+(?:\.py)?)`", table, re.M)}
    examples = {p.name for p in (ROOT / "examples").glob("*.py") if not p.name.startswith("_")}
    examples |= {p.name + "/" for p in (ROOT / "examples").iterdir() if p.is_dir() and any(p.glob("*.c"))}
    assert examples - rows == set(), f"examples missing from the README's table: {sorted(examples - rows)}"
    assert rows - examples == set(), f"README rows naming no example: {sorted(rows - examples)}"


def test_readme_links_every_docs_page_and_only_existing_ones():
    links = set(re.findall(r"\]\((docs/[\w./-]+\.md)(?:#[\w-]+)?\)", README))
    pages = {str(p.relative_to(ROOT)) for p in (ROOT / "docs").glob("*.md")}
    assert links - pages == set(), f"README links to missing pages: {sorted(links - pages)}"
    assert pages - links == set(), f"docs pages the README does not link: {sorted(pages - links)}"


@pytest.mark.parametrize("what,pattern", [("machine path", MACHINE_PATH), ("tracker label", TRACKER_LABEL)])
def test_no_machine_paths_or_tracker_labels_in_tracked_files(what, pattern):
    """Name the capability, not the tracker's number; say "outside the project root", not one machine's folder."""
    hits = []
    for p in tracked_text_files():
        text = p.read_text(encoding="utf-8", errors="replace")
        for m in pattern.finditer(text):
            line = text[text.rfind("\n", 0, m.start()) + 1:].split("\n", 1)[0]
            hits.append(f"{p.relative_to(ROOT)}:{text.count(chr(10), 0, m.start()) + 1}: {line.strip()[:100]}")
    assert not hits, f"{what}s:\n" + "\n".join(hits[:20])


def test_cited_documents_are_in_the_project():
    if (ROOT / DESIGN_DOC).exists():
        pytest.skip(f"{DESIGN_DOC} is part of the project")
    hits = [str(p.relative_to(ROOT)) for p in tracked_text_files()
            if DESIGN_DOC in p.read_text(encoding="utf-8", errors="replace")]
    assert not hits, f"cite what the project contains (docs/...), not {DESIGN_DOC}: {hits}"


def test_test_files_have_unique_names():
    # the test folders are not packages: pytest imports each file by its basename, and a second file of the same
    # name in another folder stops the whole collection
    names: dict[str, list[str]] = {}
    for p in sorted((ROOT / "tests").rglob("test_*.py")):
        names.setdefault(p.name, []).append(str(p.relative_to(ROOT)))
    assert {n: ps for n, ps in names.items() if len(ps) > 1} == {}
