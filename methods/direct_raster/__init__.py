"""``direct-raster``: rasterized direct light from the spot light with a cube shadow map.

The calibration method of the suite (effect ``direct``): if camera, spot fall-off, albedo or image
orientation disagreed with the Mitsuba reference, this method would show it first.

Stages: ``gbuffer`` (scene → position/normal/albedo), ``shadow`` (6 faces of a distance atlas seen
from the light), ``shade`` (compute pass: albedo/π · I · falloff · cos/d² · V).

==================  ========  ====================================================================
Parameter           Default   Meaning
==================  ========  ====================================================================
``shadow_size``     1024      texels per cube face of the shadow atlas
``normal_offset``   1.5       shadow-lookup offset along the normal, in shadow-map texels
``depth_bias``      1e-3      constant distance bias, as a fraction of the scene diagonal
==================  ========  ====================================================================
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from harness.gpu import GLSL_DIR, read_texture
from harness.scene import Camera
from methods.base import Method, ParamsBase, Result, param
from methods.gbuffer import mat_bytes

# Cube faces in atlas order: (forward, up), as in the OpenGL cube-map convention.
CUBE_FACES = (((1, 0, 0), (0, -1, 0)), ((-1, 0, 0), (0, -1, 0)), ((0, 1, 0), (0, 0, 1)),
              ((0, -1, 0), (0, 0, -1)), ((0, 0, 1), (0, -1, 0)), ((0, 0, -1), (0, -1, 0)))


def cube_face_matrices(position, near: float, far: float) -> list[np.ndarray]:
    """View-projection of the six 90° faces around ``position``."""
    p = np.asarray(position, np.float64)
    out = []
    for fwd, up in CUBE_FACES:
        cam = Camera(tuple(p), tuple(p + np.array(fwd)), up, 90.0)
        out.append(cam.projection_matrix(1.0, near, far) @ cam.view_matrix())
    return out


def set_spot_uniforms(prog, light, prefix: str = "light"):
    """Write a :class:`~harness.scene.SpotLight` into the GLSL ``SpotLight`` struct uniform."""
    cut, beam = np.radians(light.cutoff_angle), np.radians(light.beam_width)
    prog[f"{prefix}.position"].value = tuple(light.position)
    prog[f"{prefix}.axis"].value = tuple(light.direction())
    prog[f"{prefix}.intensity"].value = tuple(light.intensity)
    prog[f"{prefix}.cutoff"].value = float(cut)
    prog[f"{prefix}.cos_cutoff"].value = float(np.cos(cut))
    prog[f"{prefix}.beam"].value = float(beam)


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
        from harness.effects import Effect

        Effect("direct").check_scene(scene)  # the one rule for "needs a light"
        self.light = scene.lights[0]
        self.setup_scene(gpu, scene)
        s = self.params.shadow_size
        self.shadow_prog = gpu.program(GLSL_DIR / "cube_shadow.glsl")
        self.shadow_vao = self.geo.vao(self.shadow_prog)
        self.atlas = self.res.texture("shadow.atlas", (6 * s, s), 1, "f4")
        self.atlas.filter = (gpu.ctx.NEAREST, gpu.ctx.NEAREST)
        self.atlas_depth = self.res.depth_texture("shadow.depth", (6 * s, s))
        self.shadow_fbo = gpu.ctx.framebuffer([self.atlas], self.atlas_depth)
        lo, hi = scene.bounds()
        far = float(np.linalg.norm(np.maximum(np.abs(hi - self.light.position), np.abs(lo - self.light.position)))) * 1.01
        self.face_vp = cube_face_matrices(self.light.position, far * 1e-4, far)
        self.shade = gpu.compute(self.shader("shade.glsl"))
        self.shade["face_vp"].write(b"".join(mat_bytes(m) for m in self.face_vp))
        set_spot_uniforms(self.shade, self.light)
        # texel footprint at unit distance for a 90° face: 2/s; offset in world units per unit distance
        self.shade["normal_offset"].value = self.params.normal_offset * 2.0 / s
        self.shade["depth_bias"].value = self.params.depth_bias * scene.diagonal()

    def frame(self, view, effect, inputs=None):
        ctx, s = self.gpu.ctx, self.params.shadow_size
        with self.gpu.stage("gbuffer"):
            self.gbuf.render(view)
        with self.gpu.stage("shadow"):
            self.shadow_fbo.use()
            self.shadow_fbo.clear(1e30, 1e30, 1e30, 1e30, depth=1.0)
            ctx.enable(ctx.DEPTH_TEST)
            ctx.disable(ctx.CULL_FACE)
            self.shadow_prog["light_pos"].value = tuple(self.light.position)
            for i, m in enumerate(self.face_vp):
                self.shadow_fbo.viewport = (i * s, 0, s, s)
                self.shadow_prog["view_proj"].write(mat_bytes(m))
                self.shadow_vao.render()
            ctx.disable(ctx.DEPTH_TEST)
        w, h = view.width, view.height
        out = self.res.texture("output", (w, h), 4, "f4") if getattr(self, "_out_size", None) != (w, h) \
            else self.out
        self.out, self._out_size = out, (w, h)
        with self.gpu.stage("shade"):
            self.gbuf.bind(0)
            self.atlas.use(3)
            for name, unit in (("g_position", 0), ("g_normal", 1), ("g_albedo", 2), ("shadow_atlas", 3)):
                self.shade[name].value = unit
            out.bind_to_image(0, read=False, write=True)
            self.shade.run((w + 7) // 8, (h + 7) // 8)
            ctx.memory_barrier()  # imageStore results visible to the read-back
        return Result(image=lambda: read_texture(out, 3), mask=self.gbuf.mask, memory_bytes=self.res.by_buffer(),
                      counters={"shadow_texels": 6 * s * s})

