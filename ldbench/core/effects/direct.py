"""``direct``: radiance at the eye from the spot light after one diffuse reflection, with hard shadows.

The calibration effect: a method whose G-buffer or spot light disagrees with Mitsuba shows it here first.
Reference: deterministic, one exact evaluation per pixel (Mitsuba's ``spot`` emitter, ``twosided``
diffuse BSDF and a ``ray_test`` shadow ray); its variance is 0 and ``spp`` does not matter. No parameters.
"""
from __future__ import annotations

from dataclasses import dataclass

from ldbench.core.params import ParamsBase

from .base import ImageEffect


@dataclass(frozen=True)
class DirectParams(ParamsBase):
    pass


class Direct(ImageEffect):
    name = "direct"
    Params = DirectParams
    needs_light = True
    reference_backend = "Mitsuba 3: spot emitter, twosided diffuse, shadow ray (exact)"

    def stochastic(self, params):
        return False
