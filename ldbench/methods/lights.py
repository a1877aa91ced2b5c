"""Lights on the GPU: the spot light's GLSL uniforms and its cube shadow atlas.

:class:`CubeShadowMap` renders the distance from the light to the nearest surface into six 90° faces
laid side by side in one ``6s × s`` float texture (``ldbench/methods/glsl/lights/cube_shadow.glsl``; depth test on,
no culling), for a shading pass that looks up the face of a direction and compares distances. The
far plane encloses the scene's bounds seen from the light (+1 %), the near plane is 1e-4 of it.
``direct-raster`` shades with it and the LDI adapter's soft-shadow and indirect passes test visibility
to the light with it.
"""
from __future__ import annotations

import numpy as np

from ldbench.core.gpu import GLSL_DIR
from ldbench.core.scene import Camera

from .gbuffer import mat_bytes

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
    """Write a :class:`~ldbench.core.scene.SpotLight` into the GLSL ``SpotLight`` struct uniform."""
    cut, beam = np.radians(light.cutoff_angle), np.radians(light.beam_width)
    prog[f"{prefix}.position"].value = tuple(light.position)
    prog[f"{prefix}.axis"].value = tuple(light.direction())
    prog[f"{prefix}.intensity"].value = tuple(light.intensity)
    prog[f"{prefix}.cutoff"].value = float(cut)
    prog[f"{prefix}.cos_cutoff"].value = float(np.cos(cut))
    prog[f"{prefix}.beam"].value = float(beam)


class CubeShadowMap:
    """The cube shadow atlas of ``light`` over ``scene`` (module docstring): ``size`` texels per face,
    resources named ``shadow.*`` in ``res``. :meth:`render` draws it (time it in the caller's stage);
    :attr:`atlas` and :attr:`face_vp` are what a shading pass binds."""

    def __init__(self, gpu, geo, res, scene, light, size: int):
        self.gpu, self.light, self.size = gpu, light, int(size)
        s = self.size
        self.prog = gpu.program(GLSL_DIR / "lights/cube_shadow.glsl")
        self.vao = geo.vao(self.prog)
        self.atlas = res.texture("shadow.atlas", (6 * s, s), 1, "f4")
        self.atlas.filter = (gpu.ctx.NEAREST, gpu.ctx.NEAREST)
        self.depth = res.depth_texture("shadow.depth", (6 * s, s))
        self.fbo = gpu.ctx.framebuffer([self.atlas], self.depth)
        lo, hi = scene.bounds()
        pos = np.asarray(light.position, np.float64)
        far = float(np.linalg.norm(np.maximum(np.abs(hi - pos), np.abs(lo - pos)))) * 1.01
        self.face_vp = cube_face_matrices(light.position, far * 1e-4, far)

    def face_vp_bytes(self) -> bytes:
        """The six view-projections as a ``mat4[6]`` uniform."""
        return b"".join(mat_bytes(m) for m in self.face_vp)

    def render(self):
        ctx, s = self.gpu.ctx, self.size
        self.fbo.use()
        self.fbo.clear(1e30, 1e30, 1e30, 1e30, depth=1.0)
        ctx.enable(ctx.DEPTH_TEST)
        ctx.disable(ctx.CULL_FACE)
        self.prog["light_pos"].value = tuple(self.light.position)
        for i, m in enumerate(self.face_vp):
            self.fbo.viewport = (i * s, 0, s, s)
            self.prog["view_proj"].write(mat_bytes(m))
            self.vao.render()
        ctx.disable(ctx.DEPTH_TEST)
