"""Test configuration: the tests exercise the INSTALLED package, because the compiled kernels exist only there.

Test command (from the project root, after `pip install .` of the current tree), either of:

    .venv/bin/pytest                                   (the README's / CI's form, the venv's pytest script)
    .venv/bin/python -m pytest -p no:cacheprovider tests

(any venv works: `<venv>/bin/pip install . && <venv>/bin/python -m pytest -p no:cacheprovider tests`).
Re-run `pip install .` after any change under ancf_sym/ or generated/: the tests load the compiled libraries from
site-packages, not from the working tree. `python -m` puts the current directory (the project root) first on
sys.path, where the source tree's `ancf_sym/` (without `_kernels/`) would shadow the installed package; this file
removes the project root from sys.path before anything imports ancf_sym, and stops the run with a clear message if
ancf_sym still resolves to the source tree. Only tests/elements/test_codegen.py uses the working tree, on purpose, in a
subprocess. The tests live in folders by part (tests/statics/, tests/contact/, ...); tests/ itself is put on sys.path
here, so every folder imports the shared helpers.py.
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before anything loads NumPy/CasADi: see ancf_sym/__init__.py

import signal

import pytest

ROOT = Path(__file__).resolve().parents[1]

# Ctrl-C tests need SIGINT handled: a suite started as a background job of a non-interactive shell (CI scripts,
# `pytest &`) inherits SIGINT ignored, and so would every CLI run it starts (an ignored signal stays ignored across
# exec, a handled one is reset to its default there)
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


def _is_root(entry: str) -> bool:
    try:
        return Path(entry or os.getcwd()).resolve() == ROOT
    except OSError:
        return False


SOURCE = ROOT / "ancf_sym"  # the source package; a venv inside the project (.venv/) is fine


def _is_source(module_file: str) -> bool:
    return Path(module_file).resolve().parent == SOURCE


sys.path[:] = [p for p in sys.path if not _is_root(p)]
sys.path.insert(0, str(Path(__file__).resolve().parent))  # tests/: helpers.py
if "ancf_sym" in sys.modules and _is_source(sys.modules["ancf_sym"].__file__):
    pytest.exit(f"ancf_sym was imported from the source tree {ROOT} before tests/conftest.py ran; "
                "run the tests with `python -m pytest -p no:cacheprovider tests` from the project root", returncode=4)

import ancf_sym  # noqa: E402

if _is_source(ancf_sym.__file__):
    pytest.exit(f"ancf_sym resolves to the source tree ({ancf_sym.__file__}), not the installed package", returncode=4)
if not (Path(ancf_sym.__file__).parent / "_kernels").is_dir():
    pytest.exit(f"installed ancf_sym at {ancf_sym.__file__} has no compiled kernels: run `pip install .` first",
                returncode=4)


def pytest_report_header(config):
    return f"ancf_sym under test: {Path(ancf_sym.__file__).parent} (installed, compiled kernels)"
