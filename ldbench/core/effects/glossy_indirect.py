"""``glossy_indirect``: radiance at the eye after one glossy bounce of the spot light's direct light.

Every surface seen by the camera reflects with the normalized Phong BRDF
f(ω) = a₁ (e + 2)/(2π) max(0, ω·r)^e, r the mirror direction of the view ray about the geometric normal n₁
(facing the camera) and a₁ the surface's albedo; the incident light is the ``direct`` term (spot light,
two-sided Lambertian, hard shadows) leaving the first surface x₂ hit along ω. No direct term at x₁.

    L(x₁) = ∫_{ω·n₁ > 0} f(ω) L_direct(x₂(ω) → x₁) (ω·n₁) dω

Both sides estimate it the same way: ω from the lobe (e + 1)/(2π) cos^e α about r (cos α = u₀^(1/(e+1)),
φ = 2π u₁), weight a₁ (e + 2)/(e + 1) (ω·n₁), 0 below the surface (``ldbench/methods/ldi/gather.glsl``,
:mod:`ldbench.references.glossy_indirect`). niessner2010 §5 casts 16 such rays per pixel (no filtering).

Parameters: docs/reference/parameters.md.
"""
from __future__ import annotations

from dataclasses import dataclass

from ldbench.core.params import ParamsBase, param

from .base import ImageEffect


@dataclass(frozen=True)
class GlossyIndirectParams(ParamsBase):
    exponent: float = param(32.0, "normalized Phong exponent e of the lobe about the mirror direction (0: a cosine "
                               "lobe)", lo=0.0, hi=1e6)


class GlossyIndirect(ImageEffect):
    name = "glossy_indirect"
    Params = GlossyIndirectParams
    needs_light = True
    reference_key = "glossy_indirect"
    reference_backend = "Mitsuba 3: normalized Phong lobe sampling, next-event estimation at the hit"

    def label(self, params):
        return f"glossy_indirect-e{params.exponent:g}"
