"""Bad requests and bad inputs raise a ValueError subclass (kernels.KernelError) whose message names the argument
(element, effect, gauss, q, p, L), never a CasADi RuntimeError from deep inside the call."""
from __future__ import annotations

import numpy as np
import pytest

from ancf_sym import kernels

from helpers import kernel_input, params, straight_state

CATALOGUE = [(k["element"], k["effect"], k["gauss"]) for k in kernels.catalogue()]
IDS = [k["name"] for k in kernels.catalogue()]


def raises_naming(pattern: str):
    """pytest.raises for a ValueError whose message matches `pattern` (a word naming the argument)."""
    return pytest.raises(ValueError, match=pattern)


def test_error_type_is_a_value_error():
    assert issubclass(kernels.KernelError, ValueError) and not issubclass(kernels.KernelError, RuntimeError)


@pytest.mark.parametrize("call", [kernels.load, kernels.load_energy, kernels.parameters])
def test_unknown_names(call):
    with raises_naming(r"\belement\b.*'cable4d'"):
        call("cable4d", "bending")
    with raises_naming(r"\beffect\b.*'bendy'"):
        call("cable3d", "bendy")
    with raises_naming(r"\beffect\b.*'continuum'"):
        call("cable2d", "continuum")  # an effect of another element


def test_unknown_gauss_order():
    with raises_naming(r"\bgauss\b.*6"):
        kernels.load("cable3d", "bending", 6)
    with raises_naming(r"\bgauss\b"):
        kernels.load("cable3d", "gravity", 5)  # exact effect: no quadrature order to choose


@pytest.mark.parametrize("element,effect,gauss", CATALOGUE, ids=IDS)
def test_bad_q_and_p(element, effect, gauss):
    k = kernels.load(element, effect, gauss)
    q = kernel_input(element, effect, straight_state(element))
    p = params(element, effect, q)
    iL = kernels.parameters(element, effect).index("L")
    bad_p = lambda i, v: np.concatenate([p[:i], [v], p[i + 1:]])

    with raises_naming(r"\bq\b.*\b%d\b" % q.size):
        k(q[:-1], p)
    with raises_naming(r"\bq\b"):
        k(np.concatenate([q, [0.0]]), p)
    with raises_naming(r"\bp\b.*\b%d\b" % p.size):
        k(q, p[:-1])
    with raises_naming(r"\bp\b"):
        k(q, np.concatenate([p, [1.0]]))
    for v in (np.nan, np.inf, -np.inf):
        with raises_naming(r"\bq\[3\]"):
            k(np.concatenate([q[:3], [v], q[4:]]), p)
        with raises_naming(r"\bp\[%d\]" % (p.size - 1)):
            k(q, bad_p(p.size - 1, v))
    for L in (0.0, -0.5):
        with raises_naming(r"\bL\b"):
            k(q, bad_p(iL, L))
    e, g, H = k(q, p)  # and the good input still evaluates
    assert np.all(np.isfinite(np.asarray(H)))


def test_mass_matrix_bad_input():
    with raises_naming(r"\belement\b.*'rope'"):
        kernels.mass_matrix("rope", [1.0, 1.0])
    with raises_naming(r"\bp\b.*\b2\b"):
        kernels.mass_matrix("cable3d", [1.0, 1.0, 1.0])
    for p in ([0.0, 1.0], [-1.0, 1.0], [np.nan, 1.0], [1.0, np.inf]):
        with raises_naming(r"\bp\b.*\bL\b"):
            kernels.mass_matrix("cable3d", p)
    with raises_naming(r"\bp\b.*\bL\b"):
        kernels.mass_matrix("beam3d", [1.0, 0.05, -0.08, 7800.0])


# Keyword calls, matrix-shaped vectors and non-numeric input are checked too.

def test_keyword_call_wrong_size():
    k = kernels.load("cable3d", "bending")
    with raises_naming(r"\bq\b"):
        k(q=np.zeros(11), p=[1.0, 1.0])


def test_matrix_shaped_q():
    k = kernels.load("cable3d", "bending")
    with raises_naming(r"\bq\b"):
        k(np.zeros((3, 4)), [1.0, 1.0])


def test_non_numeric_q_names_q():
    k = kernels.load("cable3d", "bending")
    with raises_naming(r"\bq\b"):
        k("abc", [1.0, 1.0])
