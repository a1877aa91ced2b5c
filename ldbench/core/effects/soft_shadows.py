"""``soft_shadows``: direct light of the spot light turned into a spherical light of radius r.

The light keeps the spot light's intensity profile at its centre c (Mitsuba's ``spot``: I · falloff,
evaluated towards c), and its visibility becomes the fraction of the sphere's surface (uniform by area)
that x₁ sees unoccluded and above its tangent plane:

    L(x₁) = a₁/π · I · falloff(x₁ − c) · max(0, n₁·(c − x₁)/|c − x₁|) / |c − x₁|² · (1/4πr²) ∫_{|y−c|=r} V(x₁, y) dA(y)

(r = 0 is the hard-shadowed ``direct`` effect). Both sides estimate the integral with points y uniform on
the sphere (z = 1 − 2u₀, φ = 2π u₁) and a shadow ray each with t_max = |y − x₁|(1 − ShadowEpsilon), as the
``rays`` effect's ``shadow`` kind (``ldbench/methods/ldi/gather.glsl``, :mod:`ldbench.references.soft_shadows`); the
first light of the scene is the one that becomes spherical, other lights are ignored.
niessner2010 §7 (Fig. 8): 16 shadow rays per pixel.

Parameters: docs/reference/parameters.md.
"""
from __future__ import annotations

from dataclasses import dataclass

from ldbench.core.params import ParamsBase, param

from .base import ImageEffect


@dataclass(frozen=True)
class SoftShadowsParams(ParamsBase):
    light_radius: float = param(0.1, "radius of the spherical light around the spot light (world units)", lo=0.0,
                                hi=1e6)


class SoftShadows(ImageEffect):
    name = "soft_shadows"
    Params = SoftShadowsParams
    needs_light = True
    reference_key = "soft_shadows"
    reference_backend = "Mitsuba 3: unshadowed spot term x visible fraction of the light sphere (ray_test)"

    def label(self, params):
        return f"soft_shadows-r{params.light_radius:g}"
