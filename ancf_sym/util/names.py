"""Lookups by name (members, sensors, energy labels, channels) whose errors list the names that exist."""
from __future__ import annotations

from collections.abc import Iterable


class UnknownName(KeyError):
    """A name that is not there; the message lists the names that are. (A KeyError, so `except KeyError` and
    `dict.get` callers keep working; its str is the message itself, not KeyError's quoted repr.)"""

    def __init__(self, kind: str, name: object, known: Iterable):
        self.kind, self.name, self.known = kind, name, sorted(map(str, known))
        super().__init__(f"no {kind} {name!r}; the {kind}s here: {self.known}")

    def __str__(self) -> str:
        return str(self.args[0])


class NamedDict(dict):
    """A dict whose missing key raises UnknownName naming the keys it has (e.g. result.sensors["tip"])."""

    def __init__(self, items=(), kind: str = "key"):  # (items first: dataclasses.asdict and copy rebuild it so)
        super().__init__(items)
        self.kind = kind

    def __missing__(self, key):
        raise UnknownName(self.kind, key, self.keys())

    def __reduce__(self):  # picklable (results cross process boundaries in studies)
        return (self.__class__, (dict(self), self.kind))


def lookup(kind: str, name: object, known: dict | list | tuple):
    """known[name] for a dict, known.index(name) for a sequence; UnknownName if absent."""
    if isinstance(known, dict):
        if name not in known:
            raise UnknownName(kind, name, known)
        return known[name]
    if name not in known:
        raise UnknownName(kind, name, known)
    return known.index(name)
