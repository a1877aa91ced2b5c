"""``ldi``: rays traced through cube-sampled orthographic layered depth images (niessner2010).

Effects ``rays`` (diffuse, glossy, shadow, ao batches), ``indirect`` (one diffuse bounce, the paper's
8 rays per pixel and separable 11×11 Gaussian), ``glossy_indirect`` (16 rays per pixel, normalized Phong
lobe) and ``soft_shadows`` (16 shadow rays per pixel towards a spherical light).

**Directions** (:func:`methods.directions.cube_directions`): each cube face split into k × k squares,
n = 6k² directions (the paper's 96, 150, 384 LDIs are k = 4, 5, 8); ``directions`` must be 6k². The set
is antipodally symmetric and an orthographic LDI holds every depth along its axis, so by default one LDI
answers both v and −v: **3k² LDIs are stored** (``share_opposite``; the paper stored all 6k², "we
currently do not exploit this": ``share_opposite = false`` builds them all, for its memory and build
time). A ray's LDI is the cube cell of its direction (O(1); the angularly nearest direction in 93–94 %
of directions, never more than 19.4°/15.7°/10.0° away for k = 4/5/8). For odd k the paper's
axis-aligned cube has directions in the planes x = 0, y = 0, z = 0: their LDIs see axis-aligned walls
edge-on (not at all), and rays grazing such walls miss them (measured in docs/ldi.md). ``rotated`` turns the cube by a fixed rotation that
keeps every direction of k = 4, 5, 8 ≥ 0.72° away from those planes.

**LDIs**: ``resolution²`` pixels covering the scene's bounding sphere (centre = bounds centre, radius =
farthest vertex), depth = (p − c)·v, as the LDM maps (:func:`methods.layered.ortho_layers`).

**Build** (:mod:`methods.ldi.peel`): ``build = "peel"``, depth peeling (stages ``peel``, ``scan``,
``scatter``, ``canon``) into the ``linear`` layout of :mod:`methods.layered`, compacted by the GPU prefix
sum; ``build = "single_pass"``, the shared one-pass linearised arrays (``count``, ``scan``, ``fill``,
``sort``) + ``canon``: the same structure bit for bit. Payload per fragment: normal and albedo; the spot
light's direct light at a hit is computed with the cube shadow map (stage ``shadow``), as in the paper.
The LDIs are rebuilt every frame unless ``prebuild`` (built once in ``setup``, untimed, like the paper's
offline precomputation; frames then only trace).

**Trace** (``ldi_trace.glsl``): the pixel-crossing walk with the ε tolerance; ``epsilon`` and ``bias`` are
in **LDI pixels** (world = value × 2R / resolution), so the tolerance follows the discretization.
Counters: ``crossings_mean``, ``crossings_max`` (pixel crossings per ray), ``rays_ended_max_crossings``.

Stages: ``gbuffer`` (image effects), ``shadow`` (indirect, glossy), the build's, ``trace`` (rays: the
batch; image effects: tracing and shading of every pixel's rays), ``filter`` (indirect).

======================  ===========  ==========  ===================================================
Parameter               Default      Paper       Meaning
======================  ===========  ==========  ===================================================
``directions``          150          96/150/384  cube-sampled directions, 6k²
``resolution``          128          128, 512    LDI pixels per side
``rotated``             False        False       rotate the direction cube (CUBE_ROTATION; see below)
``share_opposite``      True         False       one LDI answers v and −v (3k² LDIs stored)
``build``               peel         peel        peel | single_pass (same structure)
``raster``              hardware                 single_pass: hardware raster | compute splat (same fragments)
``assembly``            direct                   single_pass: count + fill | one pass of pairs sorted by list
``prebuild``            False                    build once in setup (untimed); frames only trace
``epsilon``             1.0                      hit tolerance, LDI pixels (world ×2R/resolution)
``bias``                0.25                     tangent-plane bias of the self-hit test, LDI pixels
``max_crossings``       0                        pixel crossings per ray before giving up (0: none)
``max_layers``          1024                     depth-peeling passes at most (reaching it: degraded)
``rays_per_pixel``      0            8, 16, 16   image effects (0: indirect 8, glossy 16, soft 16)
``samples_per_dispatch``  1                      rays per pixel per dispatch of image effects (0: all)
``filter_size``         11           11          Gaussian taps of the indirect filter (0 = off; odd)
``shadow_size``         1024                     cube shadow-map texels per face (indirect, glossy)
``normal_offset``       1.5                      shadow lookup offset along n2, shadow texels
``depth_bias``          1e-3                     shadow depth bias, fraction of the scene diagonal
``seed``                0                        GPU random-number seed of the image effects
======================  ===========  ==========  ===================================================
"""
from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from harness.bindings import B
from harness.errors import LdbenchError
from harness.gpu import read_texture
from methods.base import Method, ParamsBase, Result, param
from methods.directions import CUBE_ROTATION, cube_directions, cube_k
from methods.layered import bind_ortho_layers, bounding_sphere, ortho_layers
from methods.lights import CubeShadowMap, set_spot_uniforms

from .peel import make_ldi_structure

DEFAULT_SPP = {"indirect": 8, "glossy_indirect": 16, "soft_shadows": 16}
EFFECT_CODES = {"indirect": 1, "glossy_indirect": 2, "soft_shadows": 3}
RAY_EPSILON, SHADOW_EPSILON = 8.940697e-05, 8.940697e-04  # Mitsuba's float32 RayEpsilon, ShadowEpsilon


@contextmanager
def _untimed(name):
    yield


@dataclass(frozen=True)
class LdiParams(ParamsBase):
    directions: int = param(150, "cube-sampled directions n = 6k^2 (96, 150, 384 in the paper)", lo=6, hi=6 * 64 * 64,
                            paper="96, 150, 384")
    resolution: int = param(128, "LDI pixels per side", lo=4, hi=4096, paper="128, 512")
    rotated: bool = param(False, "rotate the direction cube (methods.directions.CUBE_ROTATION): no LDI along an "
                                 "axis-aligned wall", paper=False)
    share_opposite: bool = param(True, "one LDI answers v and -v (3k^2 stored); False: all 6k^2 as the paper",
                                 paper=False)
    build: str = param("peel", "peel (depth peeling + GPU compaction) | single_pass (shared one-pass arrays)",
                       choices=("peel", "single_pass"), paper="peel")
    raster: str = param("hardware", "single_pass: fragments from the hardware raster or the compute splat (the "
                        "same fragments; docs/fast_builds.md)", choices=("hardware", "splat"), paper="hardware")
    assembly: str = param("direct", "single_pass: count + fill passes, or one pass of (list, depth) pairs sorted "
                          "by list", choices=("direct", "sort"))
    prebuild: bool = param(False, "build once in setup (untimed, the paper's precomputation); frames only trace")
    epsilon: float = param(1.0, "hit tolerance in LDI pixels (world = value * 2R / resolution)", lo=0.0, hi=1e4)
    bias: float = param(0.25, "tangent-plane bias of the self-hit test, LDI pixels", lo=0.0, hi=1e4)
    max_crossings: int = param(0, "pixel crossings per ray before the ray gives up as a miss (0: no limit)",
                               lo=0, hi=1 << 30)
    max_layers: int = param(1024, "depth-peeling passes at most", lo=1, hi=1 << 20)
    rays_per_pixel: int = param(0, "rays per pixel of image effects (0: indirect 8, glossy 16, soft shadows 16)",
                                lo=0, hi=4096, paper="8, 16, 16")
    samples_per_dispatch: int = param(1, "rays per pixel traced by one dispatch of an image effect (0: all)",
                                      lo=0, hi=4096)
    filter_size: int = param(11, "taps of the separable Gaussian on indirect light (0 = off, odd)", lo=0, hi=63,
                             paper=11)
    shadow_size: int = param(1024, "cube shadow-map texels per face", lo=16, hi=8192)
    normal_offset: float = param(1.5, "shadow lookup offset along the normal, shadow texels", lo=0.0, hi=16.0)
    depth_bias: float = param(1e-3, "shadow depth bias, fraction of the scene diagonal", lo=0.0, hi=0.1)
    seed: int = param(0, "random-number seed of the image effects", lo=0, hi=(1 << 32) - 1)

    def __post_init__(self):
        super().__post_init__()
        try:
            cube_k(self.directions)
        except ValueError as e:
            raise LdbenchError(f"parameter directions={self.directions}: {e}") from None
        if self.filter_size and self.filter_size % 2 == 0:
            raise LdbenchError(f"parameter filter_size={self.filter_size} must be odd (or 0)")
        if self.build == "peel" and (self.raster, self.assembly) != ("hardware", "direct"):
            raise LdbenchError("parameters raster and assembly apply to build = single_pass (depth peeling "
                               "rasterizes every pass on the hardware)")


class Ldi(Method):
    """Cube-sampled LDIs with pixel-crossing traversal (niessner2010 §3–5)."""

    name = "ldi"
    paper = "niessner2010"
    effects = frozenset({"rays", "indirect", "glossy_indirect", "soft_shadows"})
    Params = LdiParams

    @property
    def n_ldis(self) -> int:
        return self.params.directions // (2 if self.params.share_opposite else 1)

    def setup(self, gpu, scene):
        p = self.params
        self.setup_scene(gpu, scene)
        self.k = cube_k(p.directions)
        self.centre, self.radius = bounding_sphere(scene)
        self.rotation = CUBE_ROTATION if p.rotated else np.eye(3)
        axes = cube_directions(self.k, half=p.share_opposite, rotation=self.rotation)
        clip, rows, (u, w, v) = ortho_layers(axes, self.centre, self.radius)
        self.ls = make_ldi_structure(p.build, gpu, self.geo, self.res, layers=len(axes), width=p.resolution,
                                     max_layers=p.max_layers, max_list=64, prefix="ldi.ls.", raster=p.raster,
                                     assembly=p.assembly)
        self.ls.set_layers(clip, rows)
        basis = np.zeros((len(axes), 3, 4), np.float32)
        basis[:, 0, :3], basis[:, 1, :3], basis[:, 2, :3] = u, w, v
        self.axes_buf = self.res.buffer("ldi.axes", basis)
        self.pixel = 2.0 * self.radius / p.resolution
        self._stats = None
        self._last = None
        self._out_size = None
        self._shadow = None
        if p.prebuild:
            self.ls.build(_untimed)
            self.ls.free_scratch()

    # ---- shared uniforms ------------------------------------------------------------------------------
    def _bind_ldis(self, cs):
        p = self.params
        for name, val in (("ldi_k", self.k), ("ldi_half", int(p.share_opposite)),
                          ("ldi_eps", p.epsilon * self.pixel), ("ldi_bias", p.bias * self.pixel),
                          ("ldi_max_cross", p.max_crossings),
                          ("ldi_to_cube", tuple(float(x) for x in self.rotation.reshape(-1)))):  # Rᵀ, column-major
            if name in cs:
                cs[name].value = val
        self.ls.bind()
        bind_ortho_layers(cs, self.axes_buf, self.centre, self.radius, p.resolution)

    def _build(self):
        if not self.params.prebuild:
            self.ls.build()

    # ---- rays -----------------------------------------------------------------------------------------
    def frame(self, view, effect, inputs=None):
        if effect.name == "rays":
            return self._rays(inputs)
        if effect.name not in EFFECT_CODES:
            raise LdbenchError(f"method 'ldi' does not render effect {effect.name!r}")
        return self._image(view, effect)

    def _rays(self, batch):
        if batch is None:
            raise LdbenchError("method 'ldi': the rays effect needs its ray batch")
        gpu, n = self.gpu, len(batch)
        self._build()
        if getattr(self, "_hits_n", None) != n:
            self.hits = self.res.buffer("ldi.ray_hits", reserve=4 * n)
            self._hits_n = n
        cs = gpu.compute(self.shader("trace_rays.glsl"), self.ls.defines())
        cs["n_rays"].value = n
        with gpu.stage("trace"):
            self._bind_ldis(cs)
            batch.upload(gpu).bind_to_storage_buffer(B.RAYS)
            self.hits.bind_to_storage_buffer(B.HITS)
            cs.run(-(-n // 64))
            gpu.ctx.memory_barrier()
        self._last = ("rays", batch)
        hits = self.hits
        return Result(arrays={"t": lambda: np.frombuffer(self.gpu.read(hits), np.float32).copy()},
                      memory_bytes=self.res.by_buffer(), counters=self._counters, invariants=self.ls.invariants)

    def ray_stats(self, batch) -> np.ndarray:
        """(N, 2) uint32 per ray of ``batch``: pixel crossings, LDI index | ended << 31 (untimed dispatch)."""
        n = len(batch)
        out = self.gpu.ctx.buffer(reserve=8 * n)
        try:
            cs = self.gpu.compute(self.shader("trace_rays.glsl"), {**self.ls.defines(), "LDI_STATS": 1})
            cs["n_rays"].value = n
            self._bind_ldis(cs)
            batch.upload(self.gpu).bind_to_storage_buffer(B.RAYS)
            out.bind_to_storage_buffer(B.LDI_STATS)
            cs.run(-(-n // 64))
            self.gpu.ctx.memory_barrier()
            return np.frombuffer(self.gpu.read(out), np.uint32).reshape(n, 2).copy()
        finally:
            out.release()

    # ---- image effects --------------------------------------------------------------------------------
    def _shadow_map(self) -> CubeShadowMap:
        """The spot light's cube shadow atlas (methods/lights.py), made at its first use."""
        if self._shadow is None:
            self._shadow = CubeShadowMap(self.gpu, self.geo, self.res, self.scene, self.scene.lights[0],
                                         self.params.shadow_size)
        return self._shadow

    def _render_shadow(self):
        sm = self._shadow_map()
        with self.gpu.stage("shadow"):
            sm.render()

    def spp_for(self, effect) -> int:
        return self.params.rays_per_pixel or DEFAULT_SPP[effect.name]

    def _gather_program(self, effect, stats: bool = False):
        d = {**self.ls.defines(), "EFFECT": EFFECT_CODES[effect.name]}
        if stats:
            d["LDI_STATS"] = 1
        return self.gpu.compute(self.shader("gather.glsl"), d)

    def _set_gather_uniforms(self, cs, view, effect):

        p, light = self.params, self.scene.lights[0]
        set_spot_uniforms(cs, light)
        values = {"spp": self.spp_for(effect), "seed": p.seed, "ray_eps": RAY_EPSILON,
                  "eye": tuple(float(x) for x in view.camera.origin), "g_position": 0, "g_normal": 1, "g_albedo": 2}
        values["seed"] = self.seed_for(values["seed"])  # mixed with the run's seed (unchanged at seed 0)
        self.gbuf.bind(0)
        if effect.name == "soft_shadows":
            values.update(light_radius=float(effect.light_radius), shadow_eps=SHADOW_EPSILON)
        else:
            sm = self._shadow_map()
            sm.atlas.use(3)
            cs["face_vp"].write(sm.face_vp_bytes())
            values.update(shadow_atlas=3, normal_offset=p.normal_offset * 2.0 / p.shadow_size,
                          depth_bias=p.depth_bias * self.scene.diagonal())
            if effect.name == "glossy_indirect":
                values["exponent"] = float(effect.exponent)
        for name, v in values.items():
            if name in cs:  # the compiler drops what an effect's variant does not use
                cs[name].value = v
        self._bind_ldis(cs)

    def _image(self, view, effect):
        effect.check_scene(self.scene)  # the one "needs a light" rule
        gpu = self.gpu
        w, h = view.width, view.height
        with gpu.stage("gbuffer"):
            self.gbuf.render(view)
        if effect.name != "soft_shadows":
            self._render_shadow()
        self._build()
        if self._out_size != (w, h):
            self.out = self.res.texture("output", (w, h), 4, "f4")
            self.tmp = self.tmp2 = None
            self._out_size = (w, h)
        if effect.name == "indirect" and self.tmp is None:  # E and the filter's first pass
            self.tmp = self.res.texture("ldi.filter_tmp", (w, h), 4, "f4")
            self.tmp2 = self.res.texture("ldi.gather", (w, h), 4, "f4")
            for t in (self.tmp, self.tmp2):
                t.filter = (gpu.ctx.NEAREST, gpu.ctx.NEAREST)
        cs = self._gather_program(effect)
        target = self.tmp2 if effect.name == "indirect" else self.out
        with gpu.stage("trace"):
            self._set_gather_uniforms(cs, view, effect)
            self._dispatch(cs, target, effect, w, h)
        if effect.name == "indirect":
            self._filter(w, h)
        self._last = ("image", view, effect)
        out = self.out
        return Result(image=lambda: read_texture(out, 3), mask=self.gbuf.mask, memory_bytes=self.res.by_buffer(),
                      counters=self._counters, invariants=self.ls.invariants)

    def _dispatch(self, cs, target, effect, w, h):
        """The gather pass, ``samples_per_dispatch`` rays per pixel per dispatch (gather.glsl)."""
        spp, chunk = self.spp_for(effect), self.params.samples_per_dispatch or self.spp_for(effect)
        target.bind_to_image(B.OUT_IMAGE, read=True, write=True)
        for base in range(0, spp, chunk):
            cs["sample_base"].value = base
            cs["sample_count"].value = chunk
            cs.run((w + 7) // 8, (h + 7) // 8)
            self.gpu.ctx.memory_barrier()

    def _filter(self, w, h):
        """Stage ``filter``: E → separable Gaussian (if on) → × albedo (``blur.glsl``)."""
        gpu, r = self.gpu, self.params.filter_size // 2
        with gpu.stage("filter"):
            passes = [((1, 0), self.tmp2, self.tmp, False), ((0, 1), self.tmp, self.out, True)] if r else \
                [((1, 0), self.tmp2, self.out, True)]
            for axis, src, dst, final in passes:
                cs = gpu.compute(self.shader("blur.glsl"), {"FINAL": 1} if final else {})
                self.gbuf.position.use(0)
                self.gbuf.albedo.use(1)
                src.use(2)
                for name, unit in (("g_position", 0), ("g_albedo", 1), ("in_image", 2)):
                    if name in cs:
                        cs[name].value = unit
                cs["axis"].value = axis
                cs["radius"].value = r
                dst.bind_to_image(B.OUT_IMAGE, read=False, write=True)
                cs.run((w + 7) // 8, (h + 7) // 8)
                gpu.ctx.memory_barrier()

    def image_stats(self, view, effect) -> np.ndarray:
        """(H·W, 4) uint32 per pixel (row 0 at the bottom): crossings sum, max, ended rays, rays (untimed)."""
        w, h = view.width, view.height
        out = self.gpu.ctx.buffer(reserve=16 * w * h)
        scratch = self.gpu.ctx.texture((w, h), 4, dtype="f4")
        try:
            cs = self._gather_program(effect, stats=True)
            self._set_gather_uniforms(cs, view, effect)
            out.bind_to_storage_buffer(B.LDI_STATS)
            self._dispatch(cs, scratch, effect, w, h)
            return np.frombuffer(self.gpu.read(out), np.uint32).reshape(-1, 4).copy()
        finally:
            out.release()
            scratch.release()

    # ---- counters -------------------------------------------------------------------------------------
    def _counters(self) -> dict:
        c = self.ls.stats()
        p = self.params
        c.update(directions=p.directions, ldis=self.n_ldis, k=self.k, resolution=p.resolution,
                 pixel_world=self.pixel, epsilon_world=p.epsilon * self.pixel, bounding_radius=self.radius,
                 ldi_bytes=int(sum(v for k, v in self.ls.memory().items() if ".peel." not in k)))
        if self._last is not None:
            if self._last[0] == "rays":
                st = self.ray_stats(self._last[1])
                cross, ended = st[:, 0], st[:, 1] >> 31
                n = max(len(st), 1)
            else:
                st = self.image_stats(self._last[1], self._last[2])
                cross, ended = st[:, 0], st[:, 2]
                n = max(int(st[:, 3].sum()), 1)
                c["rays_per_pixel"] = self.spp_for(self._last[2])
            c.update(crossings_mean=float(cross.astype(np.float64).sum() / n),
                     crossings_max=int(st[:, 1].max() if self._last[0] != "rays" else cross.max(initial=0)),
                     rays_ended_max_crossings=int(ended.sum()), traced_rays=int(n))
        return c
