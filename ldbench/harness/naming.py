"""Names made from user text: file-name components and machine keys.

Two rules, each in one place:

:func:`slug` — a file or folder name inside a run, report or history directory (image files,
figures, grids, history plots): ASCII letters and digits and ``- _ .`` are kept, case included (image
names keep the method's and scene's spelling, e.g. ``ldm-ao-ao-step-dinf-64x64``); every run of other
characters becomes one ``_``; leading dots and ``_`` at either end are dropped, so the result is never
hidden, never ``.``/``..`` and never holds a path separator: user text (a scene or suite name such as
``../../x``) cannot leave the directory it is joined to.

:func:`key_slug` — an identifier that names one thing across runs and machines (the readable part of
``machine_key``, hence of the history file names): lower case, runs of anything but ``a-z0-9`` become
one ``-``. History files already written depend on it: do not change it.
"""
from __future__ import annotations

import re

_FILE_UNSAFE = re.compile(r"[^A-Za-z0-9._-]+")
_FILE_ENDS = re.compile(r"^[._]+|_+$")
_KEY_UNSAFE = re.compile(r"[^a-z0-9]+")


def slug(text, n: int = 80, fallback: str = "x") -> str:
    """File-name-safe form of ``text`` (see the module docstring), at most ``n`` characters;
    ``fallback`` when nothing is left."""
    s = _FILE_ENDS.sub("", _FILE_UNSAFE.sub("_", str(text if text is not None else "")))
    return s[:n].rstrip("_") or fallback


def key_slug(text, n: int, fallback: str = "unknown") -> str:
    """Lower-case, ``-``-separated form of ``text`` for keys (see the module docstring), at most ``n``
    characters; ``fallback`` when nothing is left."""
    s = _KEY_UNSAFE.sub("-", str(text or "").lower()).strip("-")
    return s[:n].strip("-") or fallback
