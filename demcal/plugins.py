"""One shape for every plug-in registry: a name maps to an entry, the entry to the plug-in.

demcal has six kinds of plug-in, each with its registry beside the code that
uses it: the optimizer's strategies, surrogates, response models and initial
designs (:mod:`demcal.optimizer.registry`), the engines
(:mod:`demcal.engines`) and the scenes (:mod:`demcal.scenes`). A
:class:`Registry` maps a name to an :class:`Entry`: the plug-in itself, or
its import path ``"module:attribute"`` so that the module is imported only
when the plug-in is first used, plus whatever the code around it must know
without importing it (a kind adds those fields in a subclass of
:class:`Entry`). Looking up an unknown name raises :class:`UnknownPlugin`,
which lists the known names.

This module imports nothing heavy: the settings and the study validate
names against the registries before any plug-in is loaded.
"""

from __future__ import annotations

import pkgutil
from dataclasses import dataclass
from typing import Any, Generic, TypeVar


class UnknownPlugin(KeyError):
    """A name no registry entry carries; the message lists the names that do."""

    def __str__(self) -> str:
        return str(self.args[0])


@dataclass(frozen=True)
class Entry:
    """A registered plug-in: ``target`` is the object or ``"module:attribute"`` to import on use."""

    target: Any

    def load(self) -> Any:
        """The plug-in itself, its module imported now if ``target`` is an import path."""
        if isinstance(self.target, str):
            return pkgutil.resolve_name(self.target)
        return self.target


E = TypeVar("E", bound=Entry)


class Registry(dict[str, E], Generic[E]):
    """The plug-ins of one ``kind`` by name, in registration order (a dict of entries)."""

    def __init__(self, kind: str, entries: dict[str, E]):
        super().__init__(entries)
        self.kind = kind

    def register(self, name: str, entry: E) -> None:
        """Add ``entry`` as ``name``; a name is registered once."""
        if name in self:
            raise ValueError(f"{self.kind} {name!r} is already registered")
        self[name] = entry

    def load(self, name: str) -> Any:
        """The plug-in registered as ``name`` (see :meth:`Entry.load`)."""
        return self[name].load()

    def __missing__(self, name: str) -> E:
        raise UnknownPlugin(f"unknown {self.kind} {name!r}; known: {', '.join(self)}")
