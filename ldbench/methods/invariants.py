"""One rule, for every adapter, on a layered structure's lost fragments.

A fragment that a full pool could not store is missing from every answer built on the structure (an AO
or indirect image, a ray's hit, an OIT composite), whatever the pool policy: ``pool = "fixed"`` only
decides that the structure is never resized, not that the loss is harmless. So every adapter that builds
a layered structure lists its overflow among the violated invariants of its ``Result`` (the runner then
marks the row ``degraded``), read from the counters the structure reports (``overflow``, ``fragments``).
"""
from __future__ import annotations


def layered_invariants(structure, counters: dict) -> list[str]:
    """``structure.invariants(counters)`` plus, when the structure did not list it, its pool overflow."""
    out = list(structure.invariants(counters))
    lost = int(counters.get("overflow") or 0)
    if lost > 0 and not any("pool overflow" in line for line in out):
        out.append(f"{lost} of {counters.get('fragments', '?')} fragments not stored (pool overflow)")
    return out
