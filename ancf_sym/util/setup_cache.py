"""Numeric set-up pieces kept by the exact inputs they read (a member's mesh, the constraint matrix, the mass
matrix, the reduced coordinates and the reduced mass matrix, the fusion of a cable's kernel calls), so that a
second run of a scene whose values changed elsewhere (stiffness, loads, step size, initial state) does not
compute them again.

A key holds the inputs themselves (array bytes with dtype and shape, scalars): two keys are equal only when every
input is equal, so a hit is the value a fresh computation would give, bit for bit (no hash of the inputs stands in
for them). Cached values are shared by the runs that hit them, so their arrays are made read-only: code that
tried to change one in place would fail loudly instead of changing another run's set-up.
`ancf_sym.dynamics.clear_graph_cache()` clears this cache too.
"""
from __future__ import annotations

from typing import Any, Callable

import numpy as np
import scipy.sparse as sp

LIMIT = 64  # entries per kind: a kind that outgrows it starts again (a sweep over many structures stays bounded)

_VALUES: dict = {}  # kind -> {key: value}
_KEYS: dict = {}  # id(value) -> (value, kind, key): the key of a value this cache holds (key_of)


_FLOATS = frozenset((float, np.float64, np.float32))
_EXACT = frozenset((int, bool, np.int64, np.int32, np.bool_, bytes, type))


def array_key(*xs: Any) -> tuple:
    """An exact key of arrays, sparse matrices, scalars and the containers and objects made of them: arrays by
    dtype, shape and bytes, floats by their exact hex form (so -0.0 and 0.0 differ), every item tagged by its type
    where a tag is needed to tell it from another (a str is itself; a float is (type, hex), an array (ndarray,
    dtype, shape, bytes)), dicts and objects (dataclasses) by their type, names and values in their order, and a
    value this cache holds by its own key (the exact inputs it was made of: no walk over what it holds). Equal keys
    mean equal inputs; equal inputs in another order (a dict built otherwise) only miss. The one serialisation
    behind every key here and the compiled graphs' structure key (ancf_sym.system.graph_cache)."""
    out = []
    add = out.append
    for x in xs:
        t = type(x)
        if t is str or x is None:
            add(x)
        elif t in _FLOATS:
            add((t, float.hex(float(x))))
        elif t in _EXACT:
            add((t, x))
        elif t is tuple:
            add(array_key(*x))
        elif t is np.ndarray:
            add((t, x.dtype.str, x.shape, np.ascontiguousarray(x).tobytes()))
        elif (k := key_of(x)) is not None:
            add(k)
        elif t is list:
            add(array_key(*x))
        elif t is dict:
            add((dict, tuple(x)) + array_key(*x.values()))
        elif hasattr(t, "__dataclass_fields__") and hasattr(x, "__dict__"):
            d = vars(x)
            add((t, tuple(d)) + array_key(*d.values()))
        elif sp.issparse(x) and x.format in ("csr", "csc"):
            add((t, x.shape) + array_key(x.indptr, x.indices, x.data))
        elif sp.issparse(x):  # (the stored entries as they are: a conversion could sum duplicates)
            x = x.tocoo()
            add((t, x.shape) + array_key(x.row, x.col, x.data))
        elif isinstance(x, np.ndarray):
            add(array_key(np.asarray(x)))
        elif isinstance(x, (tuple, list)):
            add((t,) + array_key(*x))
        elif isinstance(x, dict):
            add((t, tuple(x)) + array_key(*x.values()))
        elif hasattr(x, "__dict__") and not isinstance(x, type):
            d = vars(x)
            add((t, tuple(d)) + array_key(*d.values()))
        else:
            add((t, x))
    return tuple(out)


def _freeze(v: Any) -> None:
    if isinstance(v, np.ndarray):
        v.flags.writeable = False
    elif sp.issparse(v):
        for a in ("data", "indices", "indptr", "row", "col"):
            if hasattr(v, a):
                getattr(v, a).flags.writeable = False
    elif isinstance(v, (tuple, list)):
        for x in v:
            _freeze(x)
    elif hasattr(v, "__dict__"):
        for x in vars(v).values():
            if isinstance(x, np.ndarray) or sp.issparse(x):
                _freeze(x)


def cached(kind: str, key: tuple, build: Callable[[], Any]) -> Any:
    """The value of `build()` for these exact inputs: computed on the first call with the key, then shared
    (arrays read-only)."""
    table = _VALUES.setdefault(kind, {})
    v = table.get(key)
    if v is None:
        v = build()
        if len(table) >= LIMIT:
            _drop(kind)
            table = _VALUES.setdefault(kind, {})
        _freeze(v)
        table[key] = v
        _KEYS[id(v)] = (v, kind, key)
    return v


def key_of(value: Any) -> tuple | None:
    """(kind, key) of a value this cache holds (an exact key of its inputs), else None."""
    e = _KEYS.get(id(value))
    return (e[1], e[2]) if e is not None and e[0] is value else None


def _drop(kind: str) -> None:
    for v in _VALUES.pop(kind, {}).values():
        _KEYS.pop(id(v), None)


def clear() -> None:
    """Forget every cached set-up piece."""
    _VALUES.clear()
    _KEYS.clear()
