"""Files ldbench ships beside its code: the bundled suites.

The suites live in the top-level ``suites/`` folder of a checkout; ``ldbench/harness/suites`` links to it, so
a wheel carries the same files as package data. :func:`suite_path` lets a user name a bundled suite
from anywhere: ``default``, ``default.toml`` or ``suites/default.toml`` (the form the docs use) find
``ldbench/harness/suites/default.toml`` when no such file exists relative to the current directory.
"""
from __future__ import annotations

from pathlib import Path

SUITES_DIR = Path(__file__).resolve().parent / "suites"


def bundled_suites() -> list[str]:
    """Names (file stems) of the bundled suites, sorted."""
    return sorted(p.stem for p in SUITES_DIR.glob("*.toml"))


def suite_path(spec) -> Path:
    """The suite file ``spec`` names: an existing path as given, else a bundled suite.

    A bundled suite is found by its name (``default``), its file name (``default.toml``) or the
    checkout-relative path ``suites/default.toml``. Anything else is returned unchanged, so the caller
    reports the missing file under the name the user gave.
    """
    p = Path(spec)
    if p.is_file():
        return p
    parts = p.parts
    if len(parts) == 1 or (len(parts) == 2 and parts[0] == "suites"):
        name = parts[-1] if parts[-1].endswith(".toml") else f"{parts[-1]}.toml"
        cand = SUITES_DIR / name
        if cand.is_file():
            return cand
    return p
