"""``indirect``: radiance at the eye after exactly one diffuse bounce of the spot light (LDDE paths); no
direct term.

Reference: x₁ → cosine-sampled ω → x₂ = first hit; per sample albedo₁ · L_direct(x₂ → x₁), the
``direct`` term evaluated at x₂ (:mod:`ldbench.references.integrators`). No parameters.
"""
from __future__ import annotations

from dataclasses import dataclass

from ldbench.core.params import ParamsBase

from .base import ImageEffect


@dataclass(frozen=True)
class IndirectParams(ParamsBase):
    pass


class Indirect(ImageEffect):
    name = "indirect"
    Params = IndirectParams
    needs_light = True
    reference_backend = "Mitsuba 3: one-bounce estimator, cosine sampling, next-event estimation"
