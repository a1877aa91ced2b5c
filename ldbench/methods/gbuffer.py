"""Shared GPU building blocks for the scene: triangle upload and the G-buffer pass.

:class:`SceneGeometry` uploads the scene once as a non-indexed triangle list whose vertices carry the
*face* (geometric) normal and the material id, so every pass that rasterizes the scene (G-buffer,
shadow maps, LDM/LDI builds) shares one vertex buffer and sees the same geometric normals as Mitsuba.

:class:`GBuffer` renders position / normal / albedo (and, with the hardware raster, depth) for a
:class:`~ldbench.methods.base.View`, by the hardware raster or by a compute rasterizer (docs/reference/methods/gbuffer.md).
"""
from __future__ import annotations

from functools import cached_property

import numpy as np

from ldbench.core.bindings import B
from ldbench.core.errors import LdbenchError
from ldbench.core.gpu import GLSL_DIR, read_texture
from ldbench.core.params import param

VERTEX_ATTRS = (("in_position", 3), ("in_normal", 3), ("in_material", 1))  # float32 each
LARGE_CMD_WORDS = 8  # DrawElementsIndirectCommand (5 words) padded; the compute G-buffer's indices follow it
#: gbuffer/wide_list.glsl's header: tiles, triangles, two indirect dispatches (x, y, z); its list (uvec4) follows
WIDE_HEADER = np.array([0, 0, 0, 1, 1, 0, 1, 1], np.uint32)
WIDE_TILE = 16  # pixels: gbuffer/wide_list.glsl's GB_TILE
WIDE_TILE_GROUPS, WIDE_LIST_GROUPS = 8, 20  # byte offsets of the two dispatches in that header
#: gbuffer/wide_list.glsl's GbufClip: a count (padded to 16 bytes), then per clipped triangle its polygon,
#: set up for the tile raster (GbPiece: 144 bytes)
CLIP_HEADER_BYTES, CLIP_PIECE_BYTES = 16, 144
CLIP_CAPACITY = 16384  # polygons per frame; a clipped triangle that finds no room goes to the hardware
#: gbuffer/wide_list.glsl's GbufClipList header: triangles listed, the clipper's indirect dispatch (x, y, z)
CLIP_LIST_HEADER = np.array([0, 0, 1, 1], np.uint32)
CLIP_LIST_GROUPS = 4  # byte offset of that dispatch


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
        self._triangle_positions = None

    # Host bounds for passes whose arithmetic or buffers depend on the geometry's size (the splat build): each
    # computed at its first use and kept, the geometry does not change.
    @cached_property
    def longest_edges(self) -> np.ndarray:
        """Each triangle's longest edge (world units, float64; NaN where a vertex is not finite)."""
        p = self._v[self._f].astype(np.float64)
        return np.linalg.norm(p - np.roll(p, 1, axis=1), axis=2).max(1) if len(p) else np.zeros(0)

    @cached_property
    def longest_edge(self) -> float:
        """The longest edge of any triangle (world units; NaN when a vertex is not finite)."""
        return float(self.longest_edges.max()) if len(self.longest_edges) else 0.0

    @cached_property
    def extent(self) -> np.ndarray:
        """The largest |coordinate| of any finite vertex, per axis (world units, float64): a bound on the float
        rounding of passes that project every vertex."""
        a = np.abs(self._v.astype(np.float64))
        return np.where(np.isfinite(a), a, 0.0).max(0) if len(a) else np.zeros(3)

    def triangle_positions(self):
        """Each triangle's three positions as ``vec4`` (w = 0; 48 bytes a triangle, the interleaved buffer's
        84 hold normals and materials too): for compute passes that load every triangle many times over (the
        splat build, once per batch of layers)."""
        if self._triangle_positions is None:
            p = np.zeros((self.triangles, 3, 4), np.float32)
            p[:, :, :3] = self._v[self._f]
            self._triangle_positions = self._res.buffer("geometry.triangle_positions", p)
        return self._triangle_positions

    def vao_positions(self, program):
        """An indexed vertex array with ``in_position`` only (shared vertices, 12 bytes each)."""
        if self._indexed is None:
            res = self._res
            self._indexed = (res.buffer("geometry.positions", self._v), res.buffer("geometry.indices", self._f))
        pos, idx = self._indexed
        return self.gpu.ctx.vertex_array(program, [(pos, "3f", "in_position")], index_buffer=idx,
                                         index_element_size=4)

    def vao(self, program, index_buffer=None):
        """A vertex array binding this geometry to ``program`` (attributes it lacks are skipped);
        ``index_buffer``: uint32 indices into the triangle list (a subset of its triangles)."""
        used = [(a, k) for a, k in VERTEX_ATTRS if a in program]
        fmt = " ".join(f"{k}f" if (a, k) in used else f"{4 * k}x" for a, k in VERTEX_ATTRS)
        return self.gpu.ctx.vertex_array(program, [(self.vbo, fmt, *[a for a, _ in used])],
                                         index_buffer=index_buffer, index_element_size=4)

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


RASTERS = ("hardware", "compute")


def gbuffer_param(default: str = "compute"):
    """The ``gbuffer`` parameter of an adapter that renders the camera G-buffer (hbao, gtao, ldm): which
    raster fills it (:class:`GBuffer`); both give the same textures (docs/reference/methods/gbuffer.md)."""
    return param(default, "the camera G-buffer's raster: compute (a visibility buffer rasterized in compute "
                 "shaders, then resolved; much faster where the graphics raster is slow) or hardware (one raster "
                 "pass); the same textures (docs/reference/methods/gbuffer.md)",
                 choices=RASTERS, paper="hardware")


GROUP_LIMIT = 65535
#: what the one-pass visibility buffer (each fragment's depth key and triangle id in one 64-bit atomicMin) needs
VIS64_EXTENSIONS = frozenset({"GL_ARB_gpu_shader_int64", "GL_NV_shader_atomic_int64"})


class GBuffer:
    """Position (w = hit), camera-facing geometric normal (w = material), albedo, depth.

    ``raster``: ``"hardware"`` draws the scene into the three textures and a depth texture
    (``gbuffer/gbuffer.glsl``); ``"compute"`` rasterizes a visibility buffer in compute shaders with the hardware's
    fill rule (:func:`~ldbench.methods.structures.splat.fill_rule`) and resolves it into the same three
    textures (``gbuffer/raster.glsl``, ``gbuffer/resolve.glsl``; docs/reference/methods/gbuffer.md). No consumer reads the
    depth texture, so the compute G-buffer has none. ``max_pixels``: a triangle whose viewport-clamped
    bounding box holds more pixel centres than this (or is wider or taller than 64 pixels) is rasterized in
    16 × 16 tiles by workgroups (``gbuffer/wide.glsl``) rather than by one invocation; triangles crossing
    the near or far plane are clipped (``gbuffer/clip.glsl``) and their polygons rasterized by tiles; what finds
    no room in the tile list or among ``clip_capacity`` polygons goes to the hardware (``gbuffer/large.glsl``).
    ``vis64``: the visibility buffer as one 64-bit word a pixel (depth key, triangle id) written by one
    ``atomicMin`` in one pass, instead of two 32-bit passes (depth keys, then ids); the same textures. None
    (the default): where the context has :data:`VIS64_EXTENSIONS` (NVIDIA; not llvmpipe)."""

    def __init__(self, gpu, geometry: SceneGeometry, res, raster: str = "hardware", max_pixels: int = 256,
                 vis64: bool | None = None):
        if raster not in RASTERS:
            raise LdbenchError(f"G-buffer raster {raster!r} is not one of {', '.join(RASTERS)}")
        if not 1 <= int(max_pixels) <= 64 * 64:
            raise LdbenchError(f"G-buffer max_pixels {max_pixels} is not in 1 .. 4096")
        self.gpu, self.geo, self.res = gpu, geometry, res
        self.raster, self.max_pixels = raster, int(max_pixels)
        self.size: tuple[int, int] | None = None  # of the allocated targets
        if raster == "hardware":
            self.prog = gpu.program(GLSL_DIR / "gbuffer/gbuffer.glsl")
            self.vao = geometry.vao(self.prog)
            return
        from ldbench.methods.structures.splat import fill_rule, rule_defines

        has64 = VIS64_EXTENSIONS <= set(gpu.ctx.extensions)
        if vis64 and not has64:
            raise LdbenchError(f"the one-pass visibility buffer needs {' and '.join(sorted(VIS64_EXTENSIONS))}, "
                               "which this GL context lacks")
        self.vis64 = has64 if vis64 is None else bool(vis64)
        one = {"GB_VIS64": 1} if self.vis64 else {}
        rule = {**rule_defines(fill_rule(gpu)), **one}  # the per-triangle and the tile raster share it
        self.raster_cs = gpu.compute(GLSL_DIR / "gbuffer/raster.glsl", rule)
        self.resolve_cs = gpu.compute(GLSL_DIR / "gbuffer/resolve.glsl", one)
        self.large_prog = gpu.program(GLSL_DIR / "gbuffer/large.glsl", one)
        self.wide_cs = gpu.compute(GLSL_DIR / "gbuffer/wide.glsl", rule)
        self.expand_cs = gpu.compute(GLSL_DIR / "gbuffer/wide_expand.glsl", rule)
        n = geometry.triangles
        self.clip_cs = gpu.compute(GLSL_DIR / "gbuffer/clip.glsl", rule)
        self.clip_capacity = CLIP_CAPACITY
        self.clip = res.buffer("gbuffer.clip", reserve=CLIP_HEADER_BYTES + CLIP_PIECE_BYTES * self.clip_capacity)
        self.clip_list = res.buffer("gbuffer.clip_list", reserve=CLIP_LIST_HEADER.nbytes + 4 * n)
        # a list entry per wide triangle or polygon
        self.wide = res.buffer("gbuffer.wide", reserve=WIDE_HEADER.nbytes + 16 * (n + self.clip_capacity))
        self.large = res.buffer("gbuffer.large", reserve=4 * (LARGE_CMD_WORDS + 3 * n))
        cmd = np.zeros(LARGE_CMD_WORDS, np.uint32)
        cmd[1], cmd[2] = 1, LARGE_CMD_WORDS  # one instance; the indices follow the command
        self.large.write(cmd.tobytes())
        self.vao = geometry.vao(self.large_prog, index_buffer=self.large)

    def _allocate(self, w, h):
        r = self.res
        self.position = r.texture("gbuffer.position", (w, h), 4, "f4")
        self.normal = r.texture("gbuffer.normal", (w, h), 4, "f4")
        self.albedo = r.texture("gbuffer.albedo", (w, h), 4, "f4")
        for t in (self.position, self.normal, self.albedo):
            t.filter = (self.gpu.ctx.NEAREST, self.gpu.ctx.NEAREST)
        if self.raster == "hardware":
            self.depth = r.depth_texture("gbuffer.depth", (w, h))
            self.fbo = self.gpu.ctx.framebuffer([self.position, self.normal, self.albedo], self.depth)
        else:
            self.vis = r.buffer("gbuffer.visibility", reserve=8 * w * h)
            # room for 8 viewports of tiles that hold pixels of theirs (wide triangles and the polygons of
            # clipped ones overlap), at least 65536; a triangle with a tile beyond goes to the hardware
            self.tile_capacity = max(65536, 8 * -(-w // WIDE_TILE) * -(-h // WIDE_TILE))
            self.tiles = r.buffer("gbuffer.tiles", reserve=8 * self.tile_capacity)
            self.fbo = self.gpu.ctx.empty_framebuffer((w, h))  # the hardware path's, attachment-less
        self.size = (w, h)

    @property
    def passes(self) -> tuple[int, ...]:
        """The compute raster's passes: (0,) with the one-pass visibility buffer, else (0, 1) (depth keys,
        then triangle ids)."""
        return (0,) if self.vis64 else (0, 1)

    def depth_keys(self) -> np.ndarray:
        """The visibility buffer's depth keys, H×W uint32 with row 0 at the bottom (the float bits of the
        window depth; 0xFFFFFFFF where nothing was drawn), whichever layout (a read-back; tests)."""
        w, h = self._allocated_size()
        if self.vis64:
            return np.frombuffer(self.gpu.read(self.vis, 8 * w * h), np.uint32)[1::2].reshape(h, w)
        return np.frombuffer(self.gpu.read(self.vis, 4 * w * h), np.uint32).reshape(h, w)

    def _allocated_size(self) -> tuple[int, int]:
        """(w, h) of the targets, which :meth:`render` allocates before it runs any pass."""
        assert self.size is not None, "a G-buffer pass ran before render() allocated the targets"
        return self.size

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
        if self.raster == "compute":
            vp = mat_bytes(self.view_proj(view))
            self.clear()
            for p in self.passes:
                self.compute_pass(p, vp)
                if p == 0:
                    self.clip_pass(vp)
                    self.expand_pass(vp)
                self.wide_pass(p, vp)
                self.large_pass(p, vp)
            self.resolve(view, vp)
            return
        self.prog["view_proj"].write(mat_bytes(self.view_proj(view)))
        self.prog["eye"].value = tuple(view.camera.origin)
        self.prog["size"].value = (view.width, view.height)
        self.geo.albedo.bind_to_storage_buffer(B.ALBEDO)
        self.geo.vbo.bind_to_storage_buffer(B.GBUF_VERTICES)
        self.fbo.use()
        self.fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        ctx.disable(ctx.CULL_FACE)
        ctx.enable(ctx.DEPTH_TEST)
        self.vao.render()
        ctx.disable(ctx.DEPTH_TEST)

    # ---- the compute G-buffer's passes (render runs them in order; scripts/gpu/gbuffer_bench.py times each)
    def clear(self):
        """Visibility buffer to nothing, the hardware path's index count to 0."""
        from ldbench.methods.structures.core import fill_uint

        w, h = self._allocated_size()
        fill_uint(self.gpu, self.vis, 2 * w * h, 0xFFFFFFFF)
        fill_uint(self.gpu, self.large, 1, 0)
        self.wide.write(WIDE_HEADER.tobytes())
        self.clip.write(bytes(CLIP_HEADER_BYTES))
        self.clip_list.write(CLIP_LIST_HEADER.tobytes())

    def _compute(self, cs, vp: bytes, run, **uniforms):
        """One compute pass of the compute G-buffer: ``view_proj``, ``vis_size`` and ``uniforms`` set, every
        buffer of the compute G-buffer bound (their binding points are distinct, and a program ignores those
        it does not declare), ``run(cs)`` dispatched, then a barrier."""
        cs["view_proj"].write(vp)
        cs["vis_size"].value = self._allocated_size()
        for name, value in uniforms.items():
            if name != "vis_pass" or not self.vis64:   # one pass: no vis_pass
                cs[name].value = value
        for buf, unit in ((self.geo.vbo, B.GBUF_VERTICES), (self.vis, B.GBUF_VIS), (self.large, B.GBUF_LARGE),
                          (self.wide, B.GBUF_WIDE), (self.tiles, B.GBUF_TILES), (self.clip, B.GBUF_CLIP),
                          (self.clip_list, B.GBUF_CLIP_LIST)):
            buf.bind_to_storage_buffer(unit)
        run(cs)
        self.gpu.ctx.memory_barrier()

    def compute_pass(self, p: int, vp: bytes):
        """Pass ``p`` (0: depth keys, 1: triangle ids) of the compute raster; pass 0 lists the wide
        triangles, the triangles to clip, and the triangles it leaves to the hardware."""
        self._compute(self.raster_cs, vp, lambda cs: cs.run(max(1, min(-(-self.geo.triangles // 64), GROUP_LIMIT))),
                      vis_pass=p, n_triangles=self.geo.triangles, max_pixels=self.max_pixels)

    def clip_pass(self, vp: bytes):
        """The clipper: the triangles pass 0 listed to clip, each recorded as a polygon listed for the tile raster
        (one indirect dispatch)."""
        self._compute(self.clip_cs, vp, lambda cs: cs.run_indirect(self.clip_list, CLIP_LIST_GROUPS),
                      clip_capacity=self.clip_capacity)

    def expand_pass(self, vp: bytes):
        """The tile list: the tiles of the wide triangles and polygons pass 0 and the clipper listed that hold
        pixels of theirs (one indirect dispatch; max_pixels only sorts triangles, which pass 0 did)."""
        self._compute(self.expand_cs, vp, lambda cs: cs.run_indirect(self.wide, WIDE_LIST_GROUPS),
                      tile_capacity=self.tile_capacity)

    def wide_pass(self, p: int, vp: bytes):
        """Pass ``p`` of the tile raster of the wide triangles and polygons (one indirect dispatch)."""
        self._compute(self.wide_cs, vp, lambda cs: cs.run_indirect(self.wide, WIDE_TILE_GROUPS),
                      vis_pass=p, tile_capacity=self.tile_capacity)

    def large_pass(self, p: int, vp: bytes):
        """Pass ``p`` of the hardware's draw of the listed triangles (one indirect draw)."""
        ctx, (w, h) = self.gpu.ctx, self._allocated_size()
        prog = self.large_prog
        prog["view_proj"].write(vp)
        prog["vis_size"].value = (w, h)
        if not self.vis64:
            prog["vis_pass"].value = p
        self.fbo.use()
        self.fbo.viewport = (0, 0, w, h)
        ctx.disable(ctx.DEPTH_TEST | ctx.CULL_FACE | ctx.BLEND)
        self.vao.render_indirect(self.large, ctx.TRIANGLES, 1, 0)
        ctx.memory_barrier()

    def resolve(self, view, vp: bytes):
        """Triangle ids to position / normal / albedo."""
        (w, h), cs = self._allocated_size(), self.resolve_cs
        cs["view_proj"].write(vp)
        cs["eye"].value = tuple(view.camera.origin)
        cs["vis_size"].value = (w, h)
        self.geo.albedo.bind_to_storage_buffer(B.ALBEDO)
        self.geo.vbo.bind_to_storage_buffer(B.GBUF_VERTICES)
        self.vis.bind_to_storage_buffer(B.GBUF_VIS)
        for t, unit in ((self.position, B.GBUF_POSITION), (self.normal, B.GBUF_NORMAL),
                        (self.albedo, B.GBUF_ALBEDO)):
            t.bind_to_image(unit, read=False, write=True)
        cs.run(-(-w // 8), -(-h // 8))
        self.gpu.ctx.memory_barrier()

    def large_triangles(self) -> int:
        """Triangles the last compute frame gave to the hardware (a read-back; tests and the bench)."""
        return int(np.frombuffer(self.gpu.read(self.large, 4), np.uint32)[0]) // 3

    def wide_triangles(self) -> tuple[int, int]:
        """(triangles and polygons, tiles) the last compute frame rasterized by tiles (a read-back; tests and
        the bench)."""
        head = np.frombuffer(self.gpu.read(self.wide, WIDE_HEADER.nbytes), np.uint32)
        return int(head[1]), int(min(head[0], self.tile_capacity))

    def skipped_tiles(self) -> int:
        """Tiles of the listed boxes that the last compute frame's tile list left out, as holding none of
        their triangle's or polygon's pixel centres (a read-back; tests and the bench)."""
        head = np.frombuffer(self.gpu.read(self.wide, WIDE_HEADER.nbytes), np.uint32)
        n = int(head[1])
        listed = np.frombuffer(self.gpu.read(self.wide, 16 * n, offset=WIDE_HEADER.nbytes), np.uint32) if n else \
            np.zeros(4, np.uint32)
        return int(listed[2::4].astype(np.int64).sum()) - int(head[0])

    def clipped_polygons(self) -> int:
        """Clipped triangles (their polygons) the last compute frame recorded (a read-back; tests and the
        bench)."""
        return min(int(np.frombuffer(self.gpu.read(self.clip, 4), np.uint32)[0]), self.clip_capacity)

    def bind(self, first_unit: int = 0):
        """Bind position/normal/albedo to texture units first_unit.. (for sampler2D reads)."""
        for i, t in enumerate((self.position, self.normal, self.albedo)):
            t.use(first_unit + i)

    def read(self):
        """(position H×W×4, normal H×W×4, albedo H×W×4) with row 0 at the top; for tests and masks."""
        return read_texture(self.position), read_texture(self.normal), read_texture(self.albedo)

    def mask(self) -> np.ndarray:
        return read_texture(self.position)[..., 3] > 0.5
