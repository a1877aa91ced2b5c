"""``direct-raster``: rasterized direct light from the spot light with a cube shadow map.

The calibration method of the suite (effect ``direct``): if camera, spot fall-off, albedo or image
orientation disagreed with the Mitsuba reference, this method would show it first.

Stages: ``gbuffer`` (scene → position/normal/albedo), ``shadow`` (6 faces of a distance atlas seen
from the light), ``shade`` (compute pass: albedo/π · I · falloff · cos/d² · V).

Parameters: ``ldbench methods direct-raster`` (docs/reference/parameters.md).
"""
from __future__ import annotations

from dataclasses import dataclass

from ldbench.core.bindings import B
from ldbench.core.effects import Effect
from ldbench.core.gpu import read_texture
from ldbench.core.params import ParamsBase, param
from ldbench.methods.base import Method, Result
from ldbench.methods.lights import CubeShadowMap, set_spot_uniforms


@dataclass(frozen=True)
class DirectRasterParams(ParamsBase):
    shadow_size: int = param(1024, "texels per cube face of the shadow atlas", lo=16, hi=8192)
    normal_offset: float = param(1.5, "shadow lookup offset along the normal, in shadow texels", lo=0.0, hi=16.0)
    depth_bias: float = param(1e-3, "constant shadow bias, fraction of the scene diagonal", lo=0.0, hi=0.1)


class DirectRaster(Method):
    name = "direct-raster"
    paper = "calibration"
    effects = frozenset({"direct"})
    Params = DirectRasterParams

    def setup(self, gpu, scene):
        Effect("direct").check_scene(scene)  # the one rule for "needs a light"
        self.light = scene.lights[0]
        self.setup_scene(gpu, scene)
        s = self.params.shadow_size
        self.shadow = CubeShadowMap(gpu, self.geo, self.res, scene, self.light, s)
        self.shade = gpu.compute(self.shader("shade.glsl"))
        self.shade["face_vp"].write(self.shadow.face_vp_bytes())
        set_spot_uniforms(self.shade, self.light)
        # texel footprint at unit distance for a 90° face: 2/s; offset in world units per unit distance
        self.shade["normal_offset"].value = self.params.normal_offset * 2.0 / s
        self.shade["depth_bias"].value = self.params.depth_bias * scene.diagonal()

    def frame(self, view, effect, inputs=None):
        ctx, s = self.gpu.ctx, self.params.shadow_size
        with self.gpu.stage("gbuffer"):
            self.gbuf.render(view)
        with self.gpu.stage("shadow"):
            self.shadow.render()
        w, h = view.width, view.height
        out = self.res.texture("output", (w, h), 4, "f4") if getattr(self, "_out_size", None) != (w, h) \
            else self.out
        self.out, self._out_size = out, (w, h)
        with self.gpu.stage("shade"):
            self.gbuf.bind(0)
            self.shadow.atlas.use(3)
            for name, unit in (("g_position", 0), ("g_normal", 1), ("g_albedo", 2), ("shadow_atlas", 3)):
                self.shade[name].value = unit
            out.bind_to_image(B.OUT_IMAGE, read=False, write=True)
            self.shade.run((w + 7) // 8, (h + 7) // 8)
            ctx.memory_barrier()  # imageStore results visible to the read-back
        return Result(image=lambda: read_texture(out, 3), mask=self.gbuf.mask, memory_bytes=self.res.by_buffer(),
                      counters={"shadow_texels": 6 * s * s})

