"""Shared building blocks of the order-independent-transparency adapters (``ll-oit``, ``depth-peeling``,
``dual-depth-peeling``; effect :mod:`ldbench.core.effects.oit`).

- :class:`PeelingMethod`: what the two peeling baselines share — an occlusion query per pass, the
  framebuffers they own per size, the peel program's camera uniforms and the depth-complexity counters.
- :class:`OITMethod`: the common part of the three adapters — the scene's triangles on the GPU
  (:class:`~ldbench.methods.gbuffer.SceneGeometry`), the **material table** (one ``vec4`` per material: albedo,
  opacity; SSBO binding ``B.OIT_MATERIALS``, ``oit_material[]`` in ``ldbench/methods/glsl/oit/oit.glsl``), the camera's
  clip transform and depth row, the output texture (RGBA32F: composite colour, alpha = 1 where the
  method saw at least one fragment) and its read-back as a :class:`~ldbench.methods.base.Result`.
- Depth: every method orders fragments by the *linear view depth* dot(depth_row, (p, 1)) = (p − eye)·forward,
  interpolated perspective-correctly by the rasterizer (exact for a quantity linear in world space);
  along one pixel ray it orders surfaces as the reference's distance does.
- The clip transform is the G-buffer's (:meth:`ldbench.methods.gbuffer.GBuffer.view_proj`): near and far planes
  enclosing the scene's bounds.
"""
from __future__ import annotations

import numpy as np

from ldbench.core.bindings import B
from ldbench.core.effects.oit import BACKGROUND
from ldbench.core.errors import LdbenchError
from ldbench.core.gpu import read_texture
from ldbench.methods.base import Method, Result
from ldbench.methods.gbuffer import SceneGeometry


def material_table(scene) -> np.ndarray:
    """(K, 4) float32: albedo RGB and opacity of each material (= mesh index, as Scene.merged)."""
    return np.array([[*m.albedo, m.opacity] for m in scene.meshes], np.float32)


def camera_transform(geo: SceneGeometry, view) -> tuple[np.ndarray, np.ndarray, float, float]:
    """(clip 4×4 world→clip, depth row (4,) of the linear view depth, near, far) of ``view``."""
    cam = view.camera
    _, _, fwd = cam.basis()
    eye = np.array(cam.origin)
    near, far = geo.near_far(eye, fwd)
    clip = cam.projection_matrix(view.aspect, near, far) @ cam.view_matrix()
    row = np.concatenate([fwd, [-float(fwd @ eye)]])
    return clip, row, near, far


class OITMethod(Method):
    """Base of the OIT adapters (not registered itself: no ``name``)."""

    effects = frozenset({"oit"})

    def setup(self, gpu, scene):
        self.gpu, self.scene = gpu, scene
        self.res = gpu.resources()
        self.geo = SceneGeometry(gpu, scene, self.res)
        self.materials = self.res.buffer("oit.materials", material_table(scene))
        self.out = None
        self._size = None

    def check_effect(self, effect):
        if effect.name != "oit":
            raise LdbenchError(f"method {self.name!r} computes the oit effect, not {effect.name!r}")

    def output(self, w: int, h: int):
        """The RGBA32F output texture of this size (re-allocated when the size changes)."""
        if self._size != (w, h):
            self.out = self.res.texture("oit.output", (w, h), 4, "f4")
            self._size = (w, h)
            self.resize(w, h)
        return self.out

    def resize(self, w: int, h: int):
        """Per-size allocations of a subclass (called by :meth:`output` on a new size)."""

    def camera_program(self, view, shader: str, defines=None):
        """The adapter's ``shader`` with the camera's clip transform and (where it uses it) depth row set;
        returns (program, clip, near, far)."""
        clip, row, near, far = camera_transform(self.geo, view)
        prog = self.gpu.program(self.shader(shader), defines)
        prog["clip"].write(np.ascontiguousarray(clip.T, np.float32).tobytes())
        if "depth_row" in prog:  # optimised away by some variants
            prog["depth_row"].value = tuple(float(x) for x in row)
        return prog, clip, near, far

    def set_common_uniforms(self, prog, view):
        for name, value in (("background", tuple(float(x) for x in BACKGROUND)),
                            ("size", (view.width, view.height))):
            if name in prog:
                prog[name].value = value
        self.materials.bind_to_storage_buffer(B.OIT_MATERIALS)

    def result(self, counters, invariants=()) -> Result:
        out = self.out

        def rgba():
            return read_texture(out, 4)

        return Result(image=lambda: rgba()[..., :3].copy(), mask=lambda: rgba()[..., 3] > 0.5,
                      memory_bytes=self.res.by_buffer(), counters=counters,
                      invariants=invariants if callable(invariants) else list(invariants))


def complexity_counters(count: np.ndarray) -> dict:
    """Depth-complexity counters from fragments per pixel: max, mean over covered pixels, total, pixels."""
    covered = count > 0
    return {"depth_complexity_max": int(count.max()),
            "depth_complexity_mean": float(count[covered].mean()) if covered.any() else 0.0,
            "fragments": int(count.sum()), "pixels_covered": int(covered.sum())}


class PeelingMethod(OITMethod):
    """Base of the depth-peeling adapters: one occlusion query (``self.query``, read after each pass: when
    a pass reaches no sample, every layer is peeled) and the framebuffers of the current size."""

    def setup(self, gpu, scene):
        super().setup(gpu, scene)
        self.query = gpu.ctx.query(samples=True)
        self._fbos = []

    def own(self, *fbos):
        """Release the framebuffers of the previous size and keep these."""
        for f in getattr(self, "_fbos", []):
            f.release()
        self._fbos = list(fbos)

    def release(self):
        self.own()
        super().release()
