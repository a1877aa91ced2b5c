"""``ao``: ambient occlusion / obscurance.

A(x) = (1/π) ∫ V(x, ω) cos θ dω over the hemisphere of the geometric normal facing the camera, with
V = 1 − ρ(t), t the distance to the first hit along ω. Fall-off ρ: ``step`` (ρ = 1 for t < d_max) or
``quadratic`` (ρ = 1 − (t/d_max)² for t < d_max); ``d_max = inf`` is classic AO. Background pixels hold 1.

Reference: cosine-sampled rays from Mitsuba's exact primary hit, ``ray_test``/``ray_intersect_preliminary``
with maxt = d_max (:mod:`ldbench.references.integrators`). PSNR/SSIM data range 1: AO lives in [0, 1], so one
error gives one PSNR on every scene.

Parameters: docs/reference/parameters.md.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ldbench.core.errors import LdbenchError
from ldbench.core.params import ParamsBase, param

from .base import ImageEffect

FALLOFFS = ("step", "quadratic")


@dataclass(frozen=True)
class AOParams(ParamsBase):
    d_max: float = param(math.inf, "maximum distance of an occluder (world units, > 0; inf: classic AO)")
    falloff: str = param("step", "obscurance fall-off rho(t): step (1 within d_max) or quadratic "
                         "(1 - (t/d_max)^2 within d_max)", choices=FALLOFFS)

    def __post_init__(self):
        super().__post_init__()
        if not self.d_max > 0:
            raise LdbenchError(f"effect parameter d_max must be > 0, got {self.d_max!r}")


def rho(d_max: float, falloff: str, t):
    """Obscurance ρ(t) for hit distance t (numpy): the definition every AO method shares."""
    t = np.asarray(t, dtype=np.float64)
    if falloff == "step":
        return (t < d_max).astype(np.float64)
    return np.where(t < d_max, 1.0 - (t / d_max) ** 2, 0.0)


class AO(ImageEffect):
    name = "ao"
    Params = AOParams
    channels = 1
    units = "AO units"
    background = 1.0
    data_range = 1.0
    reference_backend = "Mitsuba 3: cosine rays from the exact primary hit, maxt = d_max"

    def key(self, params):
        return {"effect": "ao", "d_max": "inf" if math.isinf(params.d_max) else params.d_max,
                "falloff": params.falloff}

    def label(self, params):
        d = "inf" if math.isinf(params.d_max) else f"{params.d_max:g}"
        return f"ao-{params.falloff}-d{d}"

    def text(self, params):
        return f"ao ({params.falloff}, d_max = {'∞' if math.isinf(params.d_max) else f'{params.d_max:g}'})"
