"""Effects: what a method computes and the reference renders (DESIGN.md, "Effects").

An :class:`Effect` is a name plus the parameters that change its definition (for ``ao``: ``d_max`` and
``falloff``). Effects are values: they are hashed into reference-cache keys and written into records.

===========  =================================================================================
``ao``       A(x) = 1/pi * integral of V(x,w) cos(theta) over the hemisphere of the geometric normal
             facing the camera; V = 1 - rho(t). ``falloff``: ``step`` (rho = 1 for t < d_max) or
             ``quadratic`` (rho = 1 - (t/d_max)^2 for t < d_max); ``d_max = inf`` is classic AO.
             Background pixels hold 1.
``direct``   radiance at the eye from the spot light after one diffuse reflection, hard shadows.
``indirect`` radiance at the eye after exactly one diffuse bounce of the spot light (LDDE).
===========  =================================================================================
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from .errors import LdbenchError

EFFECTS = ("ao", "direct", "indirect", "vpl_range", "rays", "oit")
FALLOFFS = ("step", "quadratic")
# Effects whose definition involves the scene's light.
NEEDS_LIGHT = frozenset({"direct", "indirect", "vpl_range"})


@dataclass(frozen=True)
class Effect:
    name: str
    d_max: float = math.inf  # world units; ao only
    falloff: str = "step"  # ao only

    def __post_init__(self):
        if self.name not in EFFECTS:
            raise LdbenchError(f"unknown effect {self.name!r} (known: {', '.join(EFFECTS)})")
        try:
            d = float(self.d_max)
        except (TypeError, ValueError):
            raise LdbenchError(f"effect parameter d_max must be a number or 'inf', got {self.d_max!r}")
        if not d > 0:
            raise LdbenchError(f"effect parameter d_max must be > 0, got {self.d_max!r}")
        object.__setattr__(self, "d_max", d)
        if self.falloff not in FALLOFFS:
            raise LdbenchError(f"effect parameter falloff must be one of {FALLOFFS}, got {self.falloff!r}")

    @classmethod
    def parse(cls, name: str, params: dict | None = None) -> "Effect":
        """Build from a name and a dict of effect options (``d_max``, ``falloff``); unknown keys are errors."""
        params = dict(params or {})
        unknown = set(params) - {"d_max", "falloff"}
        if unknown:
            raise LdbenchError(f"unknown effect parameter {sorted(unknown)[0]!r} for effect {name!r}")
        if name != "ao" and params:
            raise LdbenchError(f"effect {name!r} takes no parameters, got {sorted(params)}")
        return cls(name, **params)

    def key(self) -> dict:
        """JSON-able description (used in cache keys and records)."""
        if self.name == "ao":
            return {"effect": "ao", "d_max": "inf" if math.isinf(self.d_max) else self.d_max,
                    "falloff": self.falloff}
        return {"effect": self.name}

    def label(self) -> str:
        if self.name != "ao":
            return self.name
        d = "inf" if math.isinf(self.d_max) else f"{self.d_max:g}"
        return f"ao-{self.falloff}-d{d}"

    def rho(self, t):
        """Obscurance rho(t) for hit distance t (numpy), the definition shared by every AO method."""
        import numpy as np

        t = np.asarray(t, dtype=np.float64)
        if self.falloff == "step":
            return (t < self.d_max).astype(np.float64)
        return np.where(t < self.d_max, 1.0 - (t / self.d_max) ** 2, 0.0)
