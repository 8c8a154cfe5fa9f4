"""The catalog of studies: each *_studies module's STUDIES by name (imported on first use)."""
from __future__ import annotations

from ancf_sym.study.base import Study, StudyError

_MODULES = ("statics_studies", "dynamics_studies", "beam_studies", "kernel_studies")


def _registry() -> dict[str, Study]:
    import importlib
    out = {}
    for m in _MODULES:
        for s in importlib.import_module(f"ancf_sym.study.{m}").STUDIES:
            out[s.name] = s
    return out


def get_study(name: str) -> Study:
    reg = _registry()
    if name not in reg:
        raise StudyError(f"unknown study {name!r}; known: {sorted(reg)}")
    return reg[name]


def studies() -> dict[str, str]:
    """name -> title of every study."""
    return {k: s.title for k, s in sorted(_registry().items())}
