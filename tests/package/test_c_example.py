"""The C reuse example (examples/c_kernels/main.c) compiles against the installed headers and libraries, and its
output equals the Python loader's values of the same kernels.

Tolerance 1e-12 relative (the brief's): both call the same compiled functions on the same doubles and print with
%.17g, so they agree to the last bit unless the C side passes the wrong input, reads an output in the wrong order
(e.g. the Hessian row-major) or adds the two kernels wrongly.
"""
from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from ancf_sym import kernels

ROOT = Path(__file__).resolve().parents[2]
SOURCE = ROOT / "examples" / "c_kernels" / "main.c"
NAMES = ("cable3d_axial_green", "cable3d_bending")
DEFAULT = dict(L=1.2, EA=1.0e4, EI=25.0,
               q=[0.1, -0.2, 0.05, 0.95, 0.30, -0.10, 1.15, 0.35, 0.20, 0.85, -0.25, 0.40])  # as in main.c


@pytest.fixture(scope="module")
def program(tmp_path_factory):
    gcc = shutil.which("gcc")
    if gcc is None:
        pytest.fail("gcc not found: the C example test needs a C compiler")
    kdir = kernels.KERNEL_DIR
    libs = [kernels.library_path(n).name for n in NAMES]
    exe = tmp_path_factory.mktemp("c_kernels") / "cable3d_element"
    cmd = [gcc, "-O2", "-std=c99", "-Wall", "-Wextra", "-Werror", str(SOURCE), f"-I{kdir}", f"-L{kdir}",
           *[f"-l:{lib}" for lib in libs], f"-Wl,-rpath,{kdir}", "-lm", "-o", str(exe)]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, f"{' '.join(cmd)}\n{r.stderr}"
    return exe


def run(exe, *args):
    r = subprocess.run([str(exe), *(repr(float(a)) for a in args)], capture_output=True, text=True, timeout=30)
    assert r.returncode == 0, r.stderr
    out = {}
    for line in r.stdout.splitlines():
        words = line.split()
        if words[0] == "hessian":
            out.setdefault("hessian", {})[int(words[1])] = [float(x) for x in words[2:]]
        else:
            out[words[0]] = [float(x) for x in words[1:]]
    H = np.array([out["hessian"][i] for i in range(12)])
    return out["energy_axial_green"][0], out["energy_bending"][0], np.array(out["gradient"]), H


def python_values(L, EA, EI, q):
    ea, ga, Ha = kernels.load("cable3d", "axial_green")(q, [L, EA])
    eb, gb, Hb = kernels.load("cable3d", "bending")(q, [L, EI])
    return float(ea), float(eb), np.asarray(ga + gb).ravel(), np.asarray(Ha + Hb)


def assert_close(c, py):
    for name, a, b in zip(("energy_axial_green", "energy_bending", "gradient", "hessian"), c, py):
        a, b = np.asarray(a), np.asarray(b)
        assert np.max(np.abs(a - b)) <= 1e-12 * np.max(np.abs(b)), f"{name}: C {a} vs Python {b}"


def test_default_state(program):
    c = run(program)
    assert_close(c, python_values(**DEFAULT))
    assert c[0] > 0 and c[1] > 0  # a stretched, curved state: both effects are active


def test_state_from_command_line(program):
    rng = np.random.default_rng(2)
    q = np.array([0, 0, 0, 1, 0, 0, 0.9, 0, 0, 1, 0, 0]) + 0.2 * rng.uniform(-1, 1, 12)
    L, EA, EI = 0.9, 3.0e3, 7.0
    assert_close(run(program, L, EA, EI, *q), python_values(L, EA, EI, q))


def test_rejects_bad_arguments(program):
    r = subprocess.run([str(program), "1", "2"], capture_output=True, text=True, timeout=30)
    assert r.returncode == 2 and "usage" in r.stderr
    r = subprocess.run([str(program), "-1", *["1"] * 14], capture_output=True, text=True, timeout=30)
    assert r.returncode == 2 and "L must be positive" in r.stderr
