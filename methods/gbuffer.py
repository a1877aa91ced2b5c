"""Shared GPU building blocks for the scene: triangle upload and the G-buffer pass.

:class:`SceneGeometry` uploads the scene once as a non-indexed triangle list whose vertices carry the
*face* (geometric) normal and the material id, so every pass that rasterizes the scene (G-buffer,
shadow maps, LDM/LDI builds) shares one vertex buffer and sees the same geometric normals as Mitsuba.

:class:`GBuffer` renders position / normal / albedo / depth for a :class:`~ldbench.methods.base.View`.
"""
from __future__ import annotations

import numpy as np

from ldbench.core.bindings import B
from ldbench.core.gpu import GLSL_DIR, read_texture

VERTEX_ATTRS = (("in_position", 3), ("in_normal", 3), ("in_material", 1))  # float32 each


def face_normals(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    ln = np.linalg.norm(n, axis=1, keepdims=True)
    return (n / np.where(ln > 0, ln, 1)).astype(np.float32)


class SceneGeometry:
    """The scene's triangles on the GPU (one interleaved vertex buffer + an albedo SSBO)."""

    def __init__(self, gpu, scene, res):
        v, f, mid, albedo = scene.merged()
        n = face_normals(v, f)
        data = np.empty((len(f), 3, 7), np.float32)
        data[:, :, :3] = v[f]
        data[:, :, 3:6] = n[:, None, :]
        data[:, :, 6] = mid[:, None]
        self.gpu, self.scene, self._res = gpu, scene, res
        self.triangles = len(f)
        self.vbo = res.buffer("geometry.vertices", data)
        self.albedo = res.buffer("geometry.albedo", np.concatenate(
            [albedo, np.ones((len(albedo), 1), np.float32)], axis=1))
        self.lo, self.hi = scene.bounds()
        # Indexed, position-only copy for passes that need nothing but depth (layered builds run the
        # vertex shader once per *vertex* per layer instead of three times per triangle).
        self._indexed = None
        self._v, self._f = v, f

    def vao_positions(self, program):
        """An indexed vertex array with ``in_position`` only (shared vertices, 12 bytes each)."""
        if self._indexed is None:
            res = self._res
            self._indexed = (res.buffer("geometry.positions", self._v), res.buffer("geometry.indices", self._f))
        pos, idx = self._indexed
        return self.gpu.ctx.vertex_array(program, [(pos, "3f", "in_position")], index_buffer=idx,
                                         index_element_size=4)

    def vao(self, program):
        """A vertex array binding this geometry to ``program`` (attributes it lacks are skipped)."""
        used = [(a, k) for a, k in VERTEX_ATTRS if a in program]
        fmt = " ".join(f"{k}f" if (a, k) in used else f"{4 * k}x" for a, k in VERTEX_ATTRS)
        return self.gpu.ctx.vertex_array(program, [(self.vbo, fmt, *[a for a, _ in used])])

    def near_far(self, eye: np.ndarray, forward: np.ndarray) -> tuple[float, float]:
        """Clip planes enclosing the scene bounds as seen from ``eye`` along ``forward``."""
        corners = np.array([[x, y, z] for x in (self.lo[0], self.hi[0]) for y in (self.lo[1], self.hi[1])
                            for z in (self.lo[2], self.hi[2])])
        depth = (corners - eye) @ forward
        diag = float(np.linalg.norm(self.hi - self.lo))
        far = max(float(depth.max()), 1e-3 * diag) * 1.01 + 1e-3 * diag
        near = max(float(depth.min()) * 0.99, far * 1e-4)
        return near, far


def mat_bytes(m: np.ndarray) -> bytes:
    """A numpy 4×4 (column-vector convention) as GLSL column-major bytes."""
    return np.ascontiguousarray(m.T, dtype=np.float32).tobytes()


class GBuffer:
    """Position (w = hit), camera-facing geometric normal (w = material), albedo, depth."""

    def __init__(self, gpu, geometry: SceneGeometry, res):
        self.gpu, self.geo, self.res = gpu, geometry, res
        self.prog = gpu.program(GLSL_DIR / "gbuffer.glsl")
        self.vao = geometry.vao(self.prog)
        self.size = None

    def _allocate(self, w, h):
        r = self.res
        self.position = r.texture("gbuffer.position", (w, h), 4, "f4")
        self.normal = r.texture("gbuffer.normal", (w, h), 4, "f4")
        self.albedo = r.texture("gbuffer.albedo", (w, h), 4, "f4")
        self.depth = r.depth_texture("gbuffer.depth", (w, h))
        for t in (self.position, self.normal, self.albedo):
            t.filter = (self.gpu.ctx.NEAREST, self.gpu.ctx.NEAREST)
        self.fbo = self.gpu.ctx.framebuffer([self.position, self.normal, self.albedo], self.depth)
        self.size = (w, h)

    def view_proj(self, view) -> np.ndarray:
        cam = view.camera
        _, _, fwd = cam.basis()
        near, far = self.geo.near_far(np.array(cam.origin), fwd)
        return cam.projection_matrix(view.aspect, near, far) @ cam.view_matrix()

    def render(self, view):
        ctx = self.gpu.ctx
        if self.size != (view.width, view.height):
            if self.size is not None:
                self.fbo.release()
            self._allocate(view.width, view.height)
        self.prog["view_proj"].write(mat_bytes(self.view_proj(view)))
        self.prog["eye"].value = tuple(view.camera.origin)
        self.geo.albedo.bind_to_storage_buffer(B.ALBEDO)
        self.fbo.use()
        self.fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        ctx.disable(ctx.CULL_FACE)
        ctx.enable(ctx.DEPTH_TEST)
        self.vao.render()
        ctx.disable(ctx.DEPTH_TEST)

    def bind(self, first_unit: int = 0):
        """Bind position/normal/albedo to texture units first_unit.. (for sampler2D reads)."""
        for i, t in enumerate((self.position, self.normal, self.albedo)):
            t.use(first_unit + i)

    def read(self):
        """(position H×W×4, normal H×W×4, albedo H×W×4) with row 0 at the top; for tests and masks."""
        return read_texture(self.position), read_texture(self.normal), read_texture(self.albedo)

    def mask(self) -> np.ndarray:
        return read_texture(self.position)[..., 3] > 0.5
