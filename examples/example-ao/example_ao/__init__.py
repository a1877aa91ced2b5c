"""``example-ao``: normal-oriented hemisphere screen-space ambient occlusion, an ldbench plugin.

A complete, small adapter living outside ldbench (docs/reference/adapters.md walks through it). Per pixel, the
G-buffer's world position P and normal n; ``samples`` directions of a cosine-weighted hemisphere about n
(a Fibonacci spiral rotated per pixel by a hash of the pixel and the seed), each at a distance
``u · d_max`` (u a second hashed number); the sample point S is projected into the G-buffer and counts as
occluded when the surface seen at that pixel is nearer to the eye than S and within d_max of P. AO is one
minus the occluded fraction (the ``step`` falloff; ``quadratic`` weights each occluder by 1 − r²/d_max²).
An approximation: nothing behind the first depth layer or off screen occludes.

Installed, it appears in ``ldbench methods`` through its entry point (pyproject.toml).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ldbench.core.bindings import B
from ldbench.core.errors import LdbenchError
from ldbench.core.gpu import read_texture
from ldbench.core.params import ParamsBase, param
from ldbench.methods.base import Method, Result
from ldbench.methods.gbuffer import mat_bytes
from ldbench.methods.uniforms import set_uniforms


@dataclass(frozen=True)
class ExampleAOParams(ParamsBase):
    samples: int = param(16, "hemisphere samples per pixel", lo=1, hi=256)
    radius: float = param(1.0, "sample radius as a fraction of d_max (of the scene radius when d_max = inf)",
                          lo=0.01, hi=1.0)
    seed: int = param(0, "seed of the per-pixel rotation (mixed with the run's --seed)", lo=0, hi=2**31 - 1)


class ExampleAO(Method):
    name = "example-ao"
    paper = "example"
    effects = frozenset({"ao"})
    Params = ExampleAOParams

    def setup(self, gpu, scene):
        self.setup_scene(gpu, scene)  # self.res, self.geo (triangles), self.gbuf (G-buffer pass)
        self.prog = gpu.compute(self.shader("ssao.glsl"))
        self.scene_radius = 0.5 * float(scene.diagonal())
        self._size = None

    def frame(self, view, effect, inputs=None):
        if effect.name != "ao":
            raise LdbenchError(f"method 'example-ao' does not support effect {effect.name!r}")
        p, w, h = self.params, view.width, view.height
        if self._size != (w, h):
            self.ao = self.res.texture("ao", (w, h), 1, "f4")
            self._size = (w, h)
        with self.gpu.stage("gbuffer"):
            self.gbuf.render(view)
        with self.gpu.stage("ssao"):
            unbounded = math.isinf(effect.d_max)
            d_max = self.scene_radius if unbounded else float(effect.d_max)
            self.prog["view_proj"].write(mat_bytes(self.gbuf.view_proj(view)))
            set_uniforms(self.prog, g_position=0, g_normal=1, eye=tuple(view.camera.origin),
                         samples=p.samples, radius=p.radius * d_max, d_max=d_max,
                         quadratic=int(effect.falloff == "quadratic" and not unbounded),
                         seed=self.seed_for(p.seed, bits=31))
            self.gbuf.bind(0)  # units 0, 1, 2: position, normal, albedo
            self.ao.bind_to_image(B.OUT_IMAGE, read=False, write=True)
            self.prog.run((w + 7) // 8, (h + 7) // 8)
        self.gpu.ctx.memory_barrier()
        out = self.ao
        return Result(image=lambda: read_texture(out, 1), mask=self.gbuf.mask, memory_bytes=self.res.by_buffer(),
                      counters={"samples_per_pixel": p.samples})
