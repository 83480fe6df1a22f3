"""Installed versions of named packages, for the benchmark's report (used in both venvs)."""

from __future__ import annotations

from importlib import metadata


def installed_versions(names: tuple[str, ...]) -> dict[str, str]:
    """Each package's installed version, or "not installed"."""
    found = {}
    for name in names:
        try:
            found[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            found[name] = "not installed"
    return found
