"""``ldi``: rays traced through cube-sampled orthographic layered depth images (niessner2010).

Effects ``rays`` (diffuse, glossy, shadow, ao batches), ``indirect`` (one diffuse bounce, the paper's
8 rays per pixel and separable 11×11 Gaussian), ``glossy_indirect`` (16 rays per pixel, normalized Phong
lobe) and ``soft_shadows`` (16 shadow rays per pixel towards a spherical light).

**Directions** (:func:`ldbench.methods.directions.cube_directions`): each cube face split into k × k squares,
n = 6k² directions (the paper's 96, 150, 384 LDIs are k = 4, 5, 8); ``directions`` must be 6k². The set
is antipodally symmetric and an orthographic LDI holds every depth along its axis, so by default one LDI
answers both v and −v: **3k² LDIs are stored** (``share_opposite``; the paper stored all 6k², "we
currently do not exploit this": ``share_opposite = false`` builds them all, for its memory and build
time). A ray's LDI is the cube cell of its direction (O(1); the angularly nearest direction in 93–94 %
of directions, never more than 19.4°/15.7°/10.0° away for k = 4/5/8). For odd k the paper's
axis-aligned cube has directions in the planes x = 0, y = 0, z = 0: their LDIs see axis-aligned walls
edge-on (not at all), and rays grazing such walls miss them (measured in docs/reference/methods/ldi.md). ``rotated`` turns the cube by a fixed rotation that
keeps every direction of k = 4, 5, 8 ≥ 0.72° away from those planes.

**LDIs**: ``resolution²`` pixels covering the scene's bounding sphere (centre = bounds centre, radius =
farthest vertex), depth = (p − c)·v, as the LDM maps (:func:`ldbench.methods.structures.ortho_layers`).

**Build** (:mod:`ldbench.methods.structures`): ``structure.source = "peel"`` (``preset = "paper"``), depth
peeling (stages ``peel``, ``scan``, ``scatter``, ``canon``) into the ``linear`` layout, compacted by the GPU
prefix sum; ``raster`` or ``splat`` (the default), the shared one-pass linearised arrays (``emit``, ``scan``,
``fill``, ``sort`` with the default ``assembly = "sort"``) + ``canon``: the same structure (the hardware
raster's bit for bit; the compute splat's depths to float rounding). Payload per fragment: normal and
material id (shading reads the material's float albedo, no 8-bit copy); the spot light's direct light at a
hit is computed with the cube shadow map (stage ``shadow``), as in the paper.
The LDIs are rebuilt every frame unless ``prebuild`` (built once in ``setup``, untimed, like the paper's
offline precomputation; frames then only trace).

**Trace** (``ldi_trace.glsl``): the pixel-crossing walk with the ε tolerance; ``epsilon`` and ``bias`` are
in **LDI pixels** (world = value × 2R / resolution), so the tolerance follows the discretization.
Counters: ``crossings_mean``, ``crossings_max`` (pixel crossings per ray), ``rays_ended_max_crossings``.

Stages: ``gbuffer`` (image effects), ``shadow`` (indirect, glossy), the build's, ``trace`` (rays: the
batch; image effects: tracing and shading of every pixel's rays), ``filter`` (indirect).

Parameters (``ldbench methods ldi``, docs/reference/parameters.md) are grouped by role; the earlier flat
names still work (:attr:`LdiParams.renamed`; ``build = single_pass`` is ``structure.source = raster``, with
``raster = splat`` ``structure.source = splat``).
"""
from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from ldbench.core.bindings import B
from ldbench.core.conventions import RAY_EPSILON, SHADOW_EPSILON
from ldbench.core.errors import LdbenchError
from ldbench.core.gpu import read_texture
from ldbench.core.params import ParamsBase, Preset, group, param
from ldbench.methods.base import Method, Result
from ldbench.methods.directions import CUBE_ROTATION, cube_directions, cube_k
from ldbench.methods.invariants import layered_invariants
from ldbench.methods.lights import CubeShadowMap, set_spot_uniforms
from ldbench.methods.structures import (StructureSpec, bind_ortho_layers, bounding_sphere, make_structure,
                                        ortho_layers)

PAYLOAD = ("normal", "material")  # the albedo is read from the material table at a hit (exact float)

DEFAULT_SPP = {"indirect": 8, "glossy_indirect": 16, "soft_shadows": 16}
EFFECT_CODES = {"indirect": 1, "glossy_indirect": 2, "soft_shadows": 3}
FILTER_SHARPNESS = 40.0  # bilateral filter: inverse relative tolerance of the plane distance (hbao's default)


@contextmanager
def _untimed(name):
    yield


@dataclass(frozen=True)
class LdiTrace(ParamsBase):
    """The pixel-crossing walk of every ray (``trace.``)."""

    prefix = "trace."
    epsilon: float = param(1.0, "hit tolerance in LDI pixels (world = value * 2R / resolution)", lo=0.0, hi=1e4)
    bias: float = param(0.25, "tangent-plane bias of the self-hit test, LDI pixels", lo=0.0, hi=1e4)
    max_crossings: int = param(0, "pixel crossings per ray before the ray gives up as a miss (0: no limit)",
                               lo=0, hi=1 << 30)


@dataclass(frozen=True)
class LdiImage(ParamsBase):
    """The rays of every pixel of the image effects indirect, glossy_indirect, soft_shadows (``image.``)."""

    prefix = "image."
    rays_per_pixel: int = param(0, "rays per pixel (0: indirect 8, glossy 16, soft shadows 16)",
                                lo=0, hi=4096, paper="8, 16, 16")
    samples_per_dispatch: int = param(1, "rays per pixel traced by one dispatch of an image effect (0: all in "
                                      "one)", lo=0, hi=4096)
    seed: int = param(0, "seed of the GPU random numbers of the image effects' rays", lo=0, hi=(1 << 32) - 1)


@dataclass(frozen=True)
class LdiIndirect(ParamsBase):
    """The ``indirect`` effect's filter (``indirect.``)."""

    prefix = "indirect."
    filter_size: int = param(11, "taps of the separable Gaussian on indirect light (0 = off, odd)", lo=0, hi=63,
                             paper=11)
    filter_kind: str = param("gaussian", "the paper's Gaussian, or cross-bilateral (plane-distance and normal "
                             "weights: no mixing across edges)", choices=("gaussian", "bilateral"), paper="gaussian")

    def __post_init__(self):
        super().__post_init__()
        if self.filter_size and self.filter_size % 2 == 0:
            raise LdbenchError(f"parameter indirect.filter_size={self.filter_size} must be odd (or 0)")


@dataclass(frozen=True)
class LdiShadow(ParamsBase):
    """The spot light's cube shadow map of indirect and glossy_indirect (``shadow.``)."""

    prefix = "shadow."
    shadow_size: int = param(1024, "cube shadow-map texels per face", lo=16, hi=8192)
    normal_offset: float = param(1.5, "shadow lookup offset along the normal, shadow texels", lo=0.0, hi=16.0)
    depth_bias: float = param(1e-3, "shadow depth bias, fraction of the scene diagonal", lo=0.0, hi=0.1)


@dataclass(frozen=True)
class LdiParams(ParamsBase):
    directions: int = param(150, "cube-sampled directions n = 6k^2 (96, 150, 384 in the paper)", lo=6, hi=6 * 64 * 64,
                            paper="96, 150, 384")
    resolution: int = param(128, "LDI pixels per side", lo=4, hi=4096, paper="128, 512")
    rotated: bool = param(False, "rotate the direction cube (ldbench.methods.directions.CUBE_ROTATION): no LDI along an "
                                 "axis-aligned wall", paper=False)
    share_opposite: bool = param(True, "one LDI answers v and -v (3k^2 stored); False: all 6k^2 as the paper",
                                 paper=False)
    prebuild: bool = param(False, "build once in setup (untimed, the paper's precomputation); frames only trace")
    # linear arrays with normal and material id, ties at equal depth in payload order (so that every source gives
    # the peel's structure bit for bit)
    structure: StructureSpec = group(
        StructureSpec, "the LDIs: depth peeling + GPU compaction (peel), or the shared one-pass arrays from the "
        "hardware raster or the compute splat (the same fragments; docs/reference/methods/fast_builds.md)",
        expose=("source", "assembly", "max_layers", "splat_large"), choices={"source": ("peel", "raster", "splat")},
        paper={"source": "peel"}, when={"source": {"peel": {"assembly": "direct", "pool": "grow"}}},
        layout="linear", source="splat", assembly="sort", pool="lazy", payload=PAYLOAD, indexed=False, max_list=64,
        canonical=True)
    trace: LdiTrace = group(LdiTrace, "the walk of every ray")
    image: LdiImage = group(LdiImage, "effects indirect, glossy_indirect, soft_shadows: rays per pixel")
    indirect: LdiIndirect = group(LdiIndirect, "effect indirect: the filter")
    shadow: LdiShadow = group(LdiShadow, "effects indirect and glossy_indirect: the spot light's shadow map")

    presets = {"paper": Preset(
        "the paper's build: depth peeling, one layer of every pixel per pass, compacted by a prefix sum; the "
        "default stores the same arrays in one pass (a compute raster with the hardware's fill rule, its depths "
        "to float rounding; (list, depth) pairs sorted by list, ties in payload order; sized from the previous "
        "build's count, no read-back)",
        {"structure.source": "peel", "structure.assembly": "direct"})}

    renamed = {"build": "structure.source", "raster": "structure.source", "assembly": "structure.assembly",
               "max_layers": "structure.max_layers", "epsilon": "trace.epsilon", "bias": "trace.bias",
               "max_crossings": "trace.max_crossings", "rays_per_pixel": "image.rays_per_pixel",
               "samples_per_dispatch": "image.samples_per_dispatch", "seed": "image.seed",
               "filter_size": "indirect.filter_size", "shadow_size": "shadow.shadow_size",
               "normal_offset": "shadow.normal_offset", "depth_bias": "shadow.depth_bias"}

    def __post_init__(self):
        super().__post_init__()
        try:
            cube_k(self.directions)
        except ValueError as e:
            raise LdbenchError(f"parameter directions={self.directions}: {e}") from None

    @classmethod
    def upgrade(cls, values: dict) -> dict:
        """The earlier ``build`` (peel | single_pass) and ``raster`` (hardware | splat) together are
        ``structure.source``: peel, or raster | splat of the single-pass arrays."""
        values = dict(values)
        if "build" in values or "raster" in values:
            build, raster = values.pop("build", None), values.pop("raster", None)
            if build not in (None, "peel", "single_pass"):
                raise LdbenchError(f"parameter build={build!r} (now structure.source) not one of ['peel', 'single_pass']")
            if raster not in (None, "hardware", "splat"):
                raise LdbenchError(f"parameter raster={raster!r} (now structure.source) not one of ['hardware', 'splat']")
            if build != "single_pass" and raster not in (None, "hardware"):
                raise LdbenchError("parameter raster applies to build = single_pass (depth peeling rasterizes "
                                   "every pass on the hardware); now: structure.source = splat")
            if build == "single_pass":
                values["structure.source"] = "splat" if raster == "splat" else "raster"
            elif build == "peel":
                values["structure.source"] = "peel"
        return super().upgrade(values)


class Ldi(Method):
    """Cube-sampled LDIs with pixel-crossing traversal (niessner2010 §3–5)."""

    name = "ldi"
    paper = "niessner2010"
    effects = frozenset({"rays", "indirect", "glossy_indirect", "soft_shadows"})
    Params = LdiParams
    params: LdiParams

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
        self.ls = make_structure(p.structure, gpu, self.geo, self.res, layers=len(axes),
                                 width=p.resolution, prefix="ldi.ls.")
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
                          ("ldi_eps", p.trace.epsilon * self.pixel), ("ldi_bias", p.trace.bias * self.pixel),
                          ("ldi_max_cross", p.trace.max_crossings),
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
                      memory_bytes=self.res.by_buffer(), counters=self._counters, invariants=lambda c: layered_invariants(self.ls, c))

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
        """The spot light's cube shadow atlas (ldbench/methods/lights.py), made at its first use."""
        if self._shadow is None:
            self._shadow = CubeShadowMap(self.gpu, self.geo, self.res, self.scene, self.scene.lights[0],
                                         self.params.shadow.shadow_size)
        return self._shadow

    def _render_shadow(self):
        sm = self._shadow_map()
        with self.gpu.stage("shadow"):
            sm.render()

    def spp_for(self, effect) -> int:
        return self.params.image.rays_per_pixel or DEFAULT_SPP[effect.name]

    def _gather_program(self, effect, stats: bool = False):
        d = {**self.ls.defines(), "EFFECT": EFFECT_CODES[effect.name]}
        if stats:
            d["LDI_STATS"] = 1
        return self.gpu.compute(self.shader("gather.glsl"), d)

    def _set_gather_uniforms(self, cs, view, effect):

        p, light = self.params, self.scene.lights[0]
        set_spot_uniforms(cs, light)
        values = {"spp": self.spp_for(effect), "seed": p.image.seed, "ray_eps": RAY_EPSILON,
                  "eye": tuple(float(x) for x in view.camera.origin), "g_position": 0, "g_normal": 1, "g_albedo": 2}
        values["seed"] = self.seed_for(values["seed"])  # mixed with the run's seed (unchanged at seed 0)
        self.gbuf.bind(0)
        if effect.name == "soft_shadows":
            values.update(light_radius=float(effect.light_radius), shadow_eps=SHADOW_EPSILON)
        else:
            sm = self._shadow_map()
            sm.atlas.use(3)
            cs["face_vp"].write(sm.face_vp_bytes())
            self.geo.albedo.bind_to_storage_buffer(B.LS_ALBEDO)  # a hit's albedo, by its payload's material id
            values.update(shadow_atlas=3, normal_offset=p.shadow.normal_offset * 2.0 / p.shadow.shadow_size,
                          depth_bias=p.shadow.depth_bias * self.scene.diagonal())
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
            self._filter(w, h, view)
        self._last = ("image", view, effect)
        out = self.out
        return Result(image=lambda: read_texture(out, 3), mask=self.gbuf.mask, memory_bytes=self.res.by_buffer(),
                      counters=self._counters, invariants=lambda c: layered_invariants(self.ls, c))

    def _dispatch(self, cs, target, effect, w, h):
        """The gather pass, ``samples_per_dispatch`` rays per pixel per dispatch (gather.glsl)."""
        spp, chunk = self.spp_for(effect), self.params.image.samples_per_dispatch or self.spp_for(effect)
        target.bind_to_image(B.OUT_IMAGE, read=True, write=True)
        for base in range(0, spp, chunk):
            cs["sample_base"].value = base
            cs["sample_count"].value = chunk
            cs.run((w + 7) // 8, (h + 7) // 8)
            self.gpu.ctx.memory_barrier()

    def _filter(self, w, h, view):
        """Stage ``filter``: E → separable Gaussian (if on) → × albedo (``blur.glsl``)."""
        gpu, r = self.gpu, self.params.indirect.filter_size // 2
        with gpu.stage("filter"):
            passes = [((1, 0), self.tmp2, self.tmp, False), ((0, 1), self.tmp, self.out, True)] if r else \
                [((1, 0), self.tmp2, self.out, True)]
            bilateral = self.params.indirect.filter_kind == "bilateral" and r > 0
            for axis, src, dst, final in passes:
                defines = {**({"FINAL": 1} if final else {}), **({"BILATERAL": 1} if bilateral else {})}
                cs = gpu.compute(self.shader("blur.glsl"), defines)
                self.gbuf.position.use(0)
                self.gbuf.albedo.use(1)
                src.use(2)
                self.gbuf.normal.use(3)
                for name, unit in (("g_position", 0), ("g_albedo", 1), ("in_image", 2), ("g_normal", 3)):
                    if name in cs:
                        cs[name].value = unit
                for name, v in (("eye", tuple(float(x) for x in view.camera.origin)),
                                 ("sharpness", FILTER_SHARPNESS)):
                    if bilateral and name in cs:
                        cs[name].value = v
                cs["axis"].value = axis
                cs["radius"].value = r
                dst.bind_to_image(B.OUT_IMAGE, read=False, write=True)
                cs.run((w + 7) // 8, (h + 7) // 8)
                gpu.ctx.memory_barrier()

    def image_stats(self, view, effect) -> np.ndarray:
        """(H·W, 4) uint32 per pixel (row 0 at the bottom): crossings sum, max, ended rays, rays (untimed)."""
        w, h = view.width, view.height
        out = self.gpu.ctx.buffer(reserve=16 * w * h)
        out.clear()  # a background pixel writes no statistics: it reads 0, not what the memory held
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
        c.update(build="peel" if p.structure.source == "peel" else "single_pass", directions=p.directions, ldis=self.n_ldis, k=self.k, resolution=p.resolution,
                 pixel_world=self.pixel, epsilon_world=p.trace.epsilon * self.pixel, bounding_radius=self.radius,
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
