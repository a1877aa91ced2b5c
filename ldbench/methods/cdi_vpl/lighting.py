"""VPL lighting of the ``cdi-vpl`` adapter (archer2019 §3.2): reflective shadow map, VPL buffer (the range
from the CDI, random or exact), light grid (count → prefix sum → fill), shading. GLSL beside this file.

Stages (each a GPU timer query): ``rsm`` (raster from the light), ``vpl`` (the VPL buffer; the CDI
raycast when ``range = "cdi"``), ``grid_mask`` (cells holding visible surfaces, from the G-buffer),
``grid_count``, ``grid_scan`` (with the read-back of the total that sizes the index list), ``grid_fill``,
``shade``.
"""
from __future__ import annotations

import math

import numpy as np

from ldbench.core.bindings import B
from ldbench.core.conventions import RAY_EPSILON
from ldbench.core.effects.rays import RayBatch
from ldbench.core.effects.vpl_range import (RAYS_PER_VPL, ray_origins, reduce_ranges, rsm_camera,
                                            vpl_directions)
from ldbench.core.errors import LdbenchError
from ldbench.core.gpu import read_texture
from ldbench.methods.lights import set_spot_uniforms
from ldbench.methods.gbuffer import mat_bytes
from ldbench.methods.structures import fill_uint
from ldbench.methods.scan import Scan

VPL_BYTES = 48


class VplLighting:
    """The lighting half of a frame, for a method holding ``gpu``, ``res``, ``geo``, ``gbuf``, ``params``
    and (range = cdi) a CDI bound by ``bind_cdi(program)``."""

    def __init__(self, method, scene):
        self.m = method
        p, gpu, res = method.params.indirect, method.gpu, method.res
        self.gpu, self.res, self.p = gpu, res, p
        if not scene.lights:
            raise LdbenchError(f"scene {scene.name!r} has no light: cdi-vpl needs a spot light")
        self.light = scene.lights[0]
        cam = rsm_camera(self.light)
        self.R = p.rsm
        near, far = method.geo.near_far(np.array(cam.origin), cam.basis()[2])
        self.light_vp = cam.projection_matrix(1.0, near, far) @ cam.view_matrix()
        self.diag = scene.diagonal()
        self.cap = p.miss_range * self.diag
        R = self.R
        self.rsm_pos = res.texture("rsm.position", (R, R), 4, "f4")
        self.rsm_nrm = res.texture("rsm.normal", (R, R), 4, "f4")
        self.rsm_flux = res.texture("rsm.flux", (R, R), 4, "f4")
        self.rsm_depth = res.depth_texture("rsm.depth", (R, R))
        for t in (self.rsm_pos, self.rsm_nrm, self.rsm_flux):
            t.filter = (gpu.ctx.NEAREST, gpu.ctx.NEAREST)
        self.rsm_fbo = gpu.ctx.framebuffer([self.rsm_pos, self.rsm_nrm, self.rsm_flux], self.rsm_depth)
        self.rsm_prog = gpu.program(method.shader("rsm.glsl"))
        self.rsm_vao = method.geo.vao(self.rsm_prog)
        self.side = -(-R // p.vpl_step)
        self.n_vpls = self.side * self.side
        self.vpls = res.buffer("vpl.buffer", reserve=VPL_BYTES * self.n_vpls)
        # grid over the scene bounds: cubic cells, `grid` of them along the longest side
        lo, hi = scene.bounds()
        ext = np.maximum(hi - lo, 1e-6)
        self.cell = float(ext.max()) / p.grid
        self.dims = tuple(int(max(1, math.ceil(e / self.cell - 1e-9))) for e in ext)
        self.lo = lo
        self.n_cells = int(np.prod(self.dims))
        self.grid_off = res.buffer("grid.offsets", reserve=4 * (self.n_cells + 1))
        self.grid_mask = res.buffer("grid.mask", reserve=4 * self.n_cells)
        self.grid_overflow = res.buffer("grid.overflow", reserve=16)
        self.grid_cap = 0
        self.grid_idx = None
        self._grid_allocate(max(self.n_cells, 1))
        self.scan = Scan(gpu, res, "grid.scan.")
        self.ssbo_limit = int(gpu.ctx.info.get("GL_MAX_SHADER_STORAGE_BLOCK_SIZE") or (1 << 27))
        self.table = None
        self.total = 0
        self.out = None
        self._out_size = None
        if self.m.params.vpl.range == "exact":
            self._exact_table(scene)

    def _grid_allocate(self, n: int):
        self.grid_idx = self.res.buffer("grid.indices", reserve=4 * max(int(n), 1))
        self.grid_cap = max(int(n), 1)

    # ---- passes ------------------------------------------------------------------------------------
    def render_rsm(self):
        ctx = self.gpu.ctx
        prog = self.rsm_prog
        prog["light_view_proj"].write(mat_bytes(self.light_vp))
        set_spot_uniforms(prog, self.light)
        prog["texel_plane"].value = (2.0 * math.tan(math.radians(self.light.cutoff_angle)) / self.R) ** 2
        self.m.geo.albedo.bind_to_storage_buffer(B.ALBEDO)
        self.rsm_fbo.use()
        self.rsm_fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        ctx.disable(ctx.CULL_FACE | ctx.BLEND)
        ctx.enable(ctx.DEPTH_TEST)
        self.rsm_vao.render()
        ctx.disable(ctx.DEPTH_TEST)

    def _directions(self, *args, seed: int, **kw):
        """:func:`vpl_directions` with ``seed`` mixed with the run's seed, as the GPU build's hash seed."""
        return vpl_directions(*args, seed=self.m.seed_for(seed), **kw)

    def build_vpls(self):
        p = self.p
        mode = {"cdi": "VPL_RANGE_CDI", "random": "VPL_RANGE_RANDOM", "exact": "VPL_RANGE_TABLE"}[self.m.params.vpl.range]
        defines = {mode: 1, **(self.m.cdi_defines() if self.m.params.vpl.range == "cdi" else {})}
        cs = self.gpu.compute(self.m.shader("vpl_build.glsl"), defines)
        for name, v in (("rsm_size", self.R), ("vpl_step", p.vpl_step), ("vpl_side", self.side),
                        ("light_position", tuple(self.light.position)), ("cap", self.cap),
                        ("range_max", int(p.range_mode == "max")),
                        ("cos_a", math.cos(math.radians(p.cone_angle))),
                        ("sin_a", math.sin(math.radians(p.cone_angle))),
                        ("primary_reflected", int(p.primary == "reflected")), ("seed", 0),
                        ("r_min", self.m.params.vpl.r_min * self.diag), ("r_max", self.m.params.vpl.r_max * self.diag),
                        ("rsm_position", 0), ("rsm_normal", 1), ("rsm_flux", 2)):
            if name in cs:
                cs[name].value = v
        if "seed" in cs:  # the VPL hash seed, mixed with the run's seed (unchanged at seed 0)
            cs["seed"].value = self.m.seed_for(0)
        for i, t in enumerate((self.rsm_pos, self.rsm_nrm, self.rsm_flux)):
            t.use(i)
        if self.m.params.vpl.range == "cdi":
            self.m.bind_cdi(cs)
        if self.table is not None:
            self.table.bind_to_storage_buffer(B.VPL_TABLE)
        self.vpls.bind_to_storage_buffer(B.VPLS)
        cs.run(-(-self.side // 8), -(-self.side // 8))
        self.gpu.ctx.memory_barrier()

    def _grid_uniforms(self, cs):
        for name, v in (("grid_lo", tuple(float(x) for x in self.lo)), ("grid_cell", self.cell),
                        ("grid_dims", self.dims), ("grid_capacity", self.grid_cap), ("n_vpls", self.n_vpls)):
            if name in cs:
                cs[name].value = v
        self.grid_off.bind_to_storage_buffer(B.GRID_OFF)
        self.grid_idx.bind_to_storage_buffer(B.GRID_IDX)
        self.grid_mask.bind_to_storage_buffer(B.GRID_MASK)
        self.grid_overflow.bind_to_storage_buffer(B.GRID_OVERFLOW)
        self.vpls.bind_to_storage_buffer(B.VPLS)

    def grid_mask_pass(self, view):
        gpu = self.gpu
        if not self.p.depth_mask:
            fill_uint(gpu, self.grid_mask, self.n_cells, 1)
            return
        fill_uint(gpu, self.grid_mask, self.n_cells, 0)
        cs = gpu.compute(self.m.shader("grid.glsl"), {"GRID_MASK": 1})
        self._grid_uniforms(cs)
        cs["g_position"].value = 0
        self.m.gbuf.position.use(0)
        cs.run(-(-view.width // 8), -(-view.height // 8))
        gpu.ctx.memory_barrier()

    def grid_count(self):
        gpu = self.gpu
        fill_uint(gpu, self.grid_off, self.n_cells + 1, 0)
        fill_uint(gpu, self.grid_overflow, 4, 0)
        cs = gpu.compute(self.m.shader("grid.glsl"), {"GRID_COUNT": 1})
        self._grid_uniforms(cs)
        cs.run(min(-(-self.n_vpls // 64), 65535))
        gpu.ctx.memory_barrier()

    def grid_scan(self):
        n = self.n_cells
        self.scan.run(self.grid_off, n + 1)
        self.total = int(np.frombuffer(self.gpu.read(self.grid_off, 4, offset=4 * n), np.uint32)[0])
        limit = self.ssbo_limit // 4
        want = min(max(self.total, 1), limit)
        if want > self.grid_cap or want < self.grid_cap // 2:
            self._grid_allocate(want)

    def grid_fill(self):
        cs = self.gpu.compute(self.m.shader("grid.glsl"), {"GRID_FILL": 1})
        self._grid_uniforms(cs)
        cs.run(min(-(-self.n_vpls // 64), 65535))
        self.gpu.ctx.memory_barrier()

    def shade(self, view):
        gpu = self.gpu
        w, h = view.width, view.height
        if self._out_size != (w, h):
            self.out = self.res.texture("output", (w, h), 4, "f4")
            self._out_size = (w, h)
        cs = gpu.compute(self.m.shader("shade.glsl"))
        self._grid_uniforms(cs)
        for name, unit in (("g_position", 0), ("g_normal", 1), ("g_albedo", 2)):
            cs[name].value = unit
        self.m.gbuf.bind(0)
        self.out.bind_to_image(B.OUT_IMAGE, read=False, write=True)
        cs.run(-(-w // 8), -(-h // 8))
        gpu.ctx.memory_barrier()

    def frame(self, view):
        """The lighting stages after the G-buffer (and the CDI build); returns the image callable."""
        st = self.gpu.stage
        with st("rsm"):
            self.render_rsm()
        with st("vpl"):
            self.build_vpls()
        with st("grid_mask"):
            self.grid_mask_pass(view)
        with st("grid_count"):
            self.grid_count()
        with st("grid_scan"):
            self.grid_scan()
        with st("grid_fill"):
            self.grid_fill()
        with st("shade"):
            self.shade(view)
        out = self.out
        return lambda: read_texture(out, 3)

    # ---- the exact baseline: Mitsuba on the same six rays, once (the scene and the light are static) -----
    def _exact_table(self, scene):
        self.render_rsm()
        pos = read_texture(self.rsm_pos)      # row 0 = top, as the harness's RSM
        nrm = read_texture(self.rsm_nrm)
        flux = read_texture(self.rsm_flux)
        step, R, side = self.p.vpl_step, self.R, self.side
        rows_gl = np.arange(side) * step              # GL rows of the VPL texels (bottom-up)
        cols = np.arange(side) * step
        top = R - 1 - rows_gl                          # the same texels, top-down
        P = pos[top][:, cols].reshape(-1, 4)
        N = nrm[top][:, cols].reshape(-1, 4)[:, :3].astype(np.float64)
        F = flux[top][:, cols].reshape(-1, 4)
        texel = (top[:, None] * R + cols[None, :]).reshape(-1).astype(np.uint32)
        valid = (P[:, 3] > 0.5) & (F[:, :3].max(1) > 0)
        table = np.zeros(side * side, np.float32)
        if valid.any():
            y = P[valid, :3].astype(np.float64)
            w = y - np.asarray(self.light.position)
            w /= np.linalg.norm(w, axis=1, keepdims=True)
            n = N[valid]
            dirs = self._directions(n, w, texel[valid], primary=self.p.primary, cone_angle=self.p.cone_angle,
                                  seed=0)
            o = np.repeat(ray_origins(y, n, RAY_EPSILON), RAYS_PER_VPL, axis=0)
            f4 = lambda a: np.ascontiguousarray(a, np.float32)  # noqa: E731
            k = len(o)
            batch = RayBatch(f4(o), f4(dirs.reshape(-1, 3)), np.full(k, self.cap, np.float32),
                             f4(np.repeat(n, RAYS_PER_VPL, axis=0)), np.zeros(k, np.uint32), k, 1, "vpl", False)
            t = self.m.exact_distances(scene, batch)
            table[valid] = reduce_ranges(t, self.cap, self.p.range_mode)
        self.table = self.res.buffer("vpl.exact_ranges", table)

    # ---- counters ----------------------------------------------------------------------------------
    def counters(self) -> dict:
        v = np.frombuffer(self.gpu.read(self.vpls), np.float32).reshape(-1, 12)
        live = v[:, 3] > 0
        off = np.frombuffer(self.gpu.read(self.grid_off), np.uint32).astype(np.int64)
        lens = np.diff(np.concatenate([[0], off[:self.n_cells]]))
        overflow = int(np.frombuffer(self.gpu.read(self.grid_overflow, 4), np.uint32)[0])
        return {"vpls": int(live.sum()), "vpl_slots": self.n_vpls, "rsm": self.R,
                "mean_vpl_range": float(v[live, 3].mean()) if live.any() else 0.0,
                "grid_dims": list(self.dims), "grid_cell": self.cell, "grid_entries": int(self.total),
                "grid_max_list": int(lens.max()) if len(lens) else 0, "grid_overflow": overflow,
                "grid_cells_masked": int(np.frombuffer(self.gpu.read(self.grid_mask), np.uint32).astype(bool).sum())}

    def invariants(self, c: dict) -> list:
        out = []
        if c.get("grid_overflow"):
            out.append(f"{c['grid_overflow']} light-grid entries not stored (index list above the SSBO limit)")
        return out
