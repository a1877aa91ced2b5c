"""The ``transparent_dragon`` scene: the registered Stanford dragon, transparent, for order-independent
transparency."""
from __future__ import annotations

from dataclasses import dataclass

from ldbench.core.params import param
from ldbench.core.scene import Mesh, Scene

from .base import SceneBuilder, SceneParams, rgb
from .registered import build_registered


@dataclass(frozen=True)
class TransparentDragonParams(SceneParams):
    opacity: float = param(0.5, "the dragon's α for the oit effect", lo=0.0, hi=1.0)
    albedo: tuple = rgb((0.15, 0.45, 0.75), "the dragon's diffuse albedo, linear RGB in [0, 1]")


class TransparentDragon(SceneBuilder):
    """The Stanford dragon, transparent, in an opaque open box (yang2010 Table 1, Fig. 2).

    The registered ``dragon`` scene (``ldbench scenes fetch dragon`` first) with the dragon at ``opacity``
    α for the ``oit`` effect and the given ``albedo``; the floor and walls stay opaque. Camera, light and
    layout are the registered scene's."""

    name = "transparent_dragon"
    Params = TransparentDragonParams
    registered = "dragon"

    def build(self, p: TransparentDragonParams) -> Scene:
        sc = build_registered(self.registered)
        m = sc.meshes[0]
        meshes = [Mesh(m.name, m.vertices, m.faces, p.albedo, p.opacity)] + list(sc.meshes[1:])
        return Scene("transparent_dragon", meshes, sc.camera, sc.lights, source=sc.source, warnings=sc.warnings)
