"""``oit``: order-independent transparency (yang2010 §4.1, Table 1).

**Definition.** Every surface has an opacity α ∈ [0, 1] (:attr:`ldbench.core.scene.Mesh.opacity`; Mitsuba
XML: a ``mask`` BSDF, :mod:`ldbench.core.mitsuba_xml`) and the colour c = its albedo, *unlit* (no light, no
normal: the effect isolates the fragment lists and their order from any shading model). Along the
primary ray through a pixel centre, with the surfaces it crosses f₁ … fₙ in front-to-back order
(both faces count: every surface is two-sided), the pixel is front-to-back "over" compositing onto
the background B:

    C = Σᵢ Tᵢ αᵢ cᵢ + Tₙ₊₁ B,        Tᵢ = Π_{j<i} (1 − αⱼ)

B = (1, 1, 1) (:data:`BACKGROUND`, white), also the value of pixels the ray misses and of a method's
missing pixels. An opaque surface (α = 1) ends the sum: nothing behind it shows.

**Order and the tie rule.** Fragments are ordered by depth along the ray; at *equal* depth the fragment
of the lower material id (the scene's mesh order: earlier mesh in front) comes first. Fragments equal in
depth and material are identical, so their order does not matter. Exactly equal depths arise from
coincident copies of the same triangle (in the GPU raster and in the reference alike); coplanar
surfaces made of *different* triangles round to either order on both sides.

**Reference** (:mod:`ldbench.references.oit`): exact, no sampling noise — Mitsuba 3 finds every triangle the
pixel-centre ray crosses (``ray_intersect_preliminary`` re-launched from just past each hit until it
misses, one Mitsuba scene per mesh so that coincident surfaces of different meshes are all found), the
depth of each is the float64 distance from the camera to the triangle's plane, and the composite is
evaluated in float64 with this module's :func:`composite`. Methods must match it to float precision
(~1e-6); ``spp`` does not apply.

**Metrics**: those of every image effect (PSNR/SSIM/FLIP/relMSE over the pixels the reference hits,
coverage), PSNR/SSIM data range 1 (colours lie in [0, 1]). Method counters report fragments, depth
complexity (max, mean over covered pixels) and, for peeling methods, passes.

No parameters: layer caps (yang2010's "first n layers") are method parameters, scored against this
full composite.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ldbench.core.params import ParamsBase

from .base import ImageEffect

#: Background colour B (linear RGB).
BACKGROUND = (1.0, 1.0, 1.0)


@dataclass(frozen=True)
class OITParams(ParamsBase):
    pass


def composite(colors: np.ndarray, alphas: np.ndarray, background=BACKGROUND) -> np.ndarray:
    """C = Σ Tᵢ αᵢ cᵢ + Tₙ₊₁ B for one pixel's fragments in front-to-back order (numpy, float64):
    ``colors`` (n, 3), ``alphas`` (n,). The definition every OIT method and the reference share."""
    c = np.asarray(colors, np.float64).reshape(-1, 3)
    a = np.asarray(alphas, np.float64).reshape(-1)
    T = np.concatenate([[1.0], np.cumprod(1.0 - a)])
    return (T[:-1, None] * a[:, None] * c).sum(0) + T[-1] * np.asarray(background, np.float64)


def order(depths, materials) -> np.ndarray:
    """Indices that sort fragments front to back with the tie rule: by depth, then material id."""
    return np.lexsort((np.asarray(materials), np.asarray(depths)))


class OIT(ImageEffect):
    name = "oit"
    Params = OITParams
    channels = 3
    background = 1.0
    data_range = 1.0
    reference_key = "oit"
    reference_backend = ("Mitsuba 3: every intersection along the pixel-centre ray (ray_intersect_preliminary "
                         "re-launched past each hit, per mesh), composited front to back (exact)")

    def stochastic(self, params):
        return False  # exact: spp does not apply

    def preview_scale(self, reference):
        return None  # colours lie in [0, 1]: PNG previews unscaled
