"""Setting a GLSL program's uniforms from Python (docs/reference/adapters.md).

:func:`set_uniforms` sets each ``name=value`` the program declares and skips the names the GLSL
compiler optimised away (an unused uniform is not an error: a ``#define`` may remove its only use).
A misspelt name is therefore silent; :func:`set_uniforms` with ``strict=True`` raises instead.
"""
from __future__ import annotations

from ldbench.core.errors import LdbenchError


def set_uniforms(prog, strict: bool = False, **values) -> None:
    """``prog[name].value = value`` for every uniform ``prog`` has (all of them with ``strict``)."""
    for k, v in values.items():
        if k in prog:
            prog[k].value = v
        elif strict:
            raise LdbenchError(f"shader has no active uniform {k!r}")
