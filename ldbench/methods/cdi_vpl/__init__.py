"""``cdi-vpl``: a compound deep image (CDI) for VPL range determination (archer2019); effects ``vpl_range``,
``indirect`` and ``rays``.

**CDI** (§3.1): ``directions`` orthographic deep images of ``resolution``² texels over the scene's bounding
sphere (:func:`ldbench.methods.structures.ortho_layers`), directions on the upper hemisphere as ``stacks × slices`` in
spherical coordinates (:func:`ldbench.methods.directions.stacks_slices`; 169 = 13 × 13) or the zonal equal-area set
(:func:`ldbench.methods.directions.ldm_axes`), stored as linearised arrays (:mod:`ldbench.methods.structures.linear`). Build
(stages ``count``, ``scan``, ``fill``, ``sort``), a variant of the shared layered-structure module:

* ``one_pass`` (the paper): one raster of the scene per pass, each triangle swizzled to its dominant axis in
  a geometry shader, the fragment shader projecting every fragment into all the deep images
  (``ldbench/methods/glsl/layered/build_one_pass.glsl``); not conservative (holes show in the ``rays`` hit
  agreement); ``pass_directions`` > 0 splits it into passes of that many directions (1: the same CDI,
  direction by direction);
* ``brute_force``: one raster per direction in its own view (the paper's baseline: "re-rasterizes geometry
  for each unique direction"), exact at texel centres;
* ``instanced``: the per-direction raster as one instanced draw (what the ``ldm`` adapter does).

Per-pixel sort: insertion sort in registers up to ``max_list`` fragments, an exact global-memory insertion
sort for longer lists (counted: ``sort_overflow_lists``). ``cdi = "static"`` builds the CDI once in setup
(untimed; the frames then time the raycast alone, as the paper's Table 3) and, for ``vpl_range`` and
``rays``, releases the scene's triangles, which the CDI replaces (the memory column is then the CDI's).

**Rays** (``rays_tracer``, ``cdi_trace.glsl``): the deep image of the nearest direction, the one pixel
holding the ray's origin, its list stepped to the first fragment beyond the origin (backwards for rays
against the direction; ``trace.search = "binary"`` bisects the list for the same fragment); distances along that direction; self-intersection skipped with a receiver-plane
test (see the GLSL).

**VPLs** (§3.2; ``vpl_range``: the harness's VPLs and rays, :mod:`ldbench.core.effects.vpl_range`; ``indirect``:
the method's own RSM of the spot light, ``rsm``² texels, every ``vpl_step``-th in x and y): six rays per VPL,
range = mean or max of the hit distances, a miss counting ``miss_range`` × the diagonal. ``range``:
``cdi`` (the method), ``random`` (uniform in [``r_min``, ``r_max``] × the diagonal: the paper's baseline) or
``exact`` (Mitsuba on the same rays, computed once in setup: the quality bound, not a timing).

**Lighting** (``indirect``, :mod:`ldbench.methods.cdi_vpl.lighting`): 3D light grid of cubic cells (``grid`` along
the longest side) over the scene bounds, a VPL sphere binned into the cells it overlaps that hold a visible
surface (``depth_mask``), cells as linearised index lists (count → prefix sum → fill); each G-buffer pixel
summed over its cell's VPLs: diffuse, cosine terms, unshadowed, cut off at the range.

Stages: ``count``, ``scan``, ``fill``, ``sort`` (CDI); ``raycast`` (``vpl_range``, or ``random_range``,
``exact_range``); ``trace`` (``rays``); ``gbuffer``, ``rsm``, ``vpl``, ``grid_mask``, ``grid_count``,
``grid_scan``, ``grid_fill``, ``shade`` (``indirect``).

Defaults assemble the paper's one-pass CDI as sorted pairs with no read-back (the same arrays);
``preset = "paper"`` is the count + fill assembly, which every ``reproduce`` entry runs.

Parameters (``ldbench methods cdi-vpl``, docs/reference/parameters.md) are grouped by role; the earlier flat
names still work (:attr:`CdiVplParams.renamed`; ``build = brute_force`` is ``structure.source = raster`` with
``structure.instanced = false``, ``build = instanced`` the same with ``true``).
"""
from __future__ import annotations

import contextlib
from dataclasses import dataclass

import numpy as np

from ldbench.core.bindings import B
from ldbench.core.errors import LdbenchError
from ldbench.core.effects.vpl_range import reduce_ranges
from ldbench.core.params import ParamsBase, Preset, group, param
from ldbench.methods.base import Method, Result
from ldbench.methods.directions import ldm_axes, nearest_axis_table, stacks_slices, stacks_slices_shape
from ldbench.methods.invariants import layered_invariants
from ldbench.methods.structures import (StructureSpec, bind_ortho_layers, bounding_sphere, make_structure,
                                        ortho_layers)

from .lighting import VplLighting

RAY_BYTES = 48
MAX_GROUPS = 65535  # workgroups of one dispatch dimension (the shaders loop grid-stride beyond)


@dataclass(frozen=True)
class CdiTrace(ParamsBase):
    """A ray's walk through the CDI, for every effect that casts rays (``trace.``)."""

    prefix = "trace."
    bias: float = param(0.25, "self-intersection bias along the ray, in CDI texels", lo=0.0, hi=64.0)
    lookup: str = param("auto", "nearest direction of a ray: from the (theta, phi) grid (stacks_slices) or a "
                        "cube table of candidates (eqsp), or a scan of all directions", choices=("auto", "scan"),
                        paper="closest matching direction")
    search: str = param("linear", "search of a ray's list: stepped from the near end (linear) or bisected "
                        "(binary; the same entry, the list being sorted)", choices=("linear", "binary"),
                        paper="linear ('a binary search was found to be slower')")


@dataclass(frozen=True)
class CdiVplRanges(ParamsBase):
    """Where the VPL ranges come from, for ``vpl_range`` and ``indirect`` (``vpl.``)."""

    prefix = "vpl."
    range: str = param("cdi", "where the VPL ranges come from: cdi (the CDI raycast), random (uniform in "
                       "[r_min, r_max] x the scene diagonal: the paper's baseline) or exact (Mitsuba on the same "
                       "rays, once in setup: the quality bound, not a timing)",
                       choices=("cdi", "random", "exact"), paper="cdi (random: the baseline)")
    r_min: float = param(0.01, "random range: lower bound, x scene diagonal", lo=0.0, hi=10.0)
    r_max: float = param(0.25, "random range: upper bound, x scene diagonal", lo=0.0, hi=10.0)

    def __post_init__(self):
        super().__post_init__()
        if self.r_max < self.r_min:
            raise LdbenchError(f"parameter vpl.r_max={self.r_max} below vpl.r_min={self.r_min}")


@dataclass(frozen=True)
class CdiVplIndirect(ParamsBase):
    """The ``indirect`` effect: RSM, VPLs and the light grid (``indirect.``)."""

    prefix = "indirect."
    rsm: int = param(256, "reflective shadow map side R (R^2 texels) of the method's own VPLs", lo=4, hi=4096,
                     paper=256)
    vpl_step: int = param(2, "every vpl_step-th RSM texel in x and y is a VPL", lo=1, hi=64,
                          paper="about 20,000 of 65,536 texels")
    primary: str = param("normal", "primary ray of each VPL: its normal or the reflected light direction",
                         choices=("normal", "reflected"), paper="either")
    cone_angle: float = param(45.0, "angle of the five rays around the primary one (degrees)", lo=0.0, hi=89.0)
    range_mode: str = param("mean", "range = mean or max of the six distances", choices=("mean", "max"),
                            paper="either")
    miss_range: float = param(0.5, "distance of a miss (and clamp), x scene diagonal", lo=1e-4, hi=10.0)
    grid: int = param(16, "light-grid cells along the longest side of the scene bounds", lo=1, hi=256)
    depth_mask: bool = param(True, "bin VPLs only into cells holding a visible surface", paper=True)


#: the earlier ``build`` values: brute_force = the raster one draw per direction, instanced = one draw
_BUILDS = {"one_pass": {"structure.source": "one_pass"},
           "brute_force": {"structure.source": "raster", "structure.instanced": False},
           "instanced": {"structure.source": "raster", "structure.instanced": True},
           "splat": {"structure.source": "splat"}}


@dataclass(frozen=True)
class CdiVplParams(ParamsBase):
    directions: int = param(169, "number of deep images (directions)", lo=1, hi=4096, paper=169)
    direction_set: str = param("stacks_slices", "stacks x slices in spherical coordinates, or the zonal "
                               "equal-area set", choices=("stacks_slices", "eqsp"), paper="stacks_slices")
    resolution: int = param(64, "texels per side of each deep image", lo=4, hi=4096, paper=64)
    cdi: str = param("frame", "build the CDI every frame, or once in setup (static scene)",
                     choices=("frame", "static"), paper="frame")
    structure: StructureSpec = group(
        StructureSpec, "the CDI: linearised arrays; source one_pass (the paper: one raster for all directions), "
        "raster (one raster per direction: instanced = false is the paper's brute force, true one instanced "
        "draw) or splat (the instanced raster's fragments; docs/reference/methods/fast_builds.md)",
        expose=("source", "instanced", "assembly", "pool", "pass_layers", "max_list", "splat_large"),
        choices={"source": ("one_pass", "raster", "splat")},
        paper={"source": "one_pass (raster, instanced = false: the baseline)"},
        layout="linear", source="one_pass", instanced=False, max_list=128, assembly="sort", pool="lazy")
    trace: CdiTrace = group(CdiTrace, "the walk of a ray through the CDI")
    vpl: CdiVplRanges = group(CdiVplRanges, "effects vpl_range and indirect: the VPL ranges")
    indirect: CdiVplIndirect = group(CdiVplIndirect, "effect indirect: RSM, VPLs, light grid")

    presets = {"paper": Preset(
        "the paper's assembly of the one-pass CDI (count and fill passes, the arrays sized by a read-back; lists "
        "sorted in registers up to 32 fragments); the default stores the same arrays (one pass of (list, depth) "
        "pairs sorted by list, no read-back, up to 128 fragments in registers: the one-pass lists reach ~120)",
        {"structure.source": "one_pass", "structure.assembly": "direct", "structure.pool": "grow",
         "structure.max_list": 32})}

    renamed = {"build": "structure.source", "assembly": "structure.assembly", "pass_directions": "structure.pass_layers",
               "max_list": "structure.max_list", "bias": "trace.bias", "lookup": "trace.lookup",
               "range": "vpl.range", "r_min": "vpl.r_min", "r_max": "vpl.r_max",
               **{k: f"indirect.{k}" for k in ("rsm", "vpl_step", "primary", "cone_angle", "range_mode",
                                               "miss_range", "grid", "depth_mask")}}
    renamed_values = {"build": _BUILDS}


class CdiVpl(Method):
    """Compound deep image + VPL ranges + light grid (archer2019)."""

    name = "cdi-vpl"
    paper = "archer2019"
    effects = frozenset({"vpl_range", "indirect", "rays"})
    Params = CdiVplParams
    params: CdiVplParams

    # ---- setup ---------------------------------------------------------------------------------------
    def setup(self, gpu, scene):
        p = self.params
        self.setup_scene(gpu, scene)
        self.centre, self.radius = bounding_sphere(scene)
        self.axes = stacks_slices(p.directions) if p.direction_set == "stacks_slices" else ldm_axes(p.directions)
        clip, rows, (u, w, v) = ortho_layers(self.axes, self.centre, self.radius)
        self._layers = (clip, rows)
        self._basis = np.zeros((p.directions, 3, 4), np.float32)
        self._basis[:, 0, :3], self._basis[:, 1, :3], self._basis[:, 2, :3] = u, w, v
        self.texel = 2.0 * self.radius / p.resolution
        self.cdi_struct = None
        self.lighting = None
        self._out: dict = {}
        self._exact_cache = None
        self._geometry_released = False
        self._choose_lookup()
        if p.vpl.range == "cdi":
            self._cdi()
            gpu.compute(self.shader("trace.glsl"), {**self.cdi_defines(), "CDI_VPL": 1})  # compiled untimed
        elif p.vpl.range == "random":
            gpu.compute(self.shader("trace.glsl"), {"CDI_RANDOM": 1})

    def _cdi(self):
        """The CDI (created at the first use that needs it; a static one is built then, untimed)."""
        if self.cdi_struct is None:
            p = self.params
            s = make_structure(p.structure, self.gpu, self.geo, self.res, layers=p.directions, width=p.resolution,
                               prefix="cdi.", sphere=(self.centre, self.radius))
            s.set_layers(*self._layers)
            self.axes_buf = self.res.buffer("cdi.axes", self._basis)
            self.cdi_struct = s
            if p.cdi == "static":
                s.build(stage=lambda name: contextlib.nullcontext())
        return self.cdi_struct

    def cdi_defines(self) -> dict:
        d = self._cdi().defines()
        if self._lookup == "grid":
            d["CDI_GRID_LOOKUP"] = 1
        elif self._lookup == "table":
            d["CDI_TABLE_LOOKUP"] = 1
        if self.params.trace.search == "binary":
            d["CDI_BINARY_SEARCH"] = 1
        return d

    def _choose_lookup(self):
        """The nearest-direction lookup (``lookup = "auto"``): the (θ, φ) grid for stacks × slices, a cube
        table of candidates for the zonal set (the scan where no table of ≤ 4 candidates exists)."""
        p = self.params
        self._lookup, self.lut_buf, self.lut_res = "scan", None, 0
        if p.trace.lookup == "scan":
            return
        if p.direction_set == "stacks_slices":
            self._lookup = "grid"
            return
        for res in (128, 256):
            try:
                table = nearest_axis_table(self.axes, res)
            except ValueError:
                continue
            self._lookup, self.lut_res = "table", res
            self.lut_buf = self.res.buffer("cdi.lookup_table", table)
            return

    def bind_cdi(self, cs):
        """CDI uniforms and buffers of a program that includes cdi_trace.glsl."""
        p = self.params
        for name, v in (("cdi_dirs", p.directions),
                        ("cdi_bias", p.trace.bias * self.texel),
                        ("cdi_spread", 1.0 if p.structure.source == "one_pass" else 0.0),
                        ("cdi_grid", stacks_slices_shape(p.directions)), ("cdi_lut_res", self.lut_res)):
            if name in cs:
                cs[name].value = v
        self.cdi_struct.bind()
        bind_ortho_layers(cs, self.axes_buf, self.centre, self.radius, p.resolution)
        if self.lut_buf is not None:
            self.lut_buf.bind_to_storage_buffer(B.CDI_LUT)

    def _build_cdi(self):
        if self.params.cdi == "frame":
            self._cdi().build()

    def _release_geometry(self):
        """Static CDI answering rays: the triangles are not needed again (the CDI replaces them)."""
        if self._geometry_released:
            return
        for name in [k for k in self.res.objects if k.startswith("geometry.")]:
            self.res.free(name)
        self._geometry_released = True

    def _buffer(self, name: str, nbytes: int):
        buf = self._out.get(name)
        if buf is None or buf.size < nbytes:
            buf = self._out[name] = self.res.buffer(f"out.{name}", reserve=nbytes)
        return buf

    # ---- frames --------------------------------------------------------------------------------------
    def frame(self, view, effect, inputs=None):
        if effect.name == "vpl_range":
            return self._vpl_range(effect, inputs)
        if effect.name == "rays":
            return self._rays(inputs)
        if effect.name == "indirect":
            return self._indirect(view)
        raise LdbenchError(f"method 'cdi-vpl' does not compute effect {effect.name!r}")

    def _chunks(self, n_items: int, per_item_bytes: int):
        """Dispatch ranges [a, b) whose ray bindings stay below the SSBO size limit (offsets aligned)."""
        limit = int(self.gpu.ctx.info.get("GL_MAX_SHADER_STORAGE_BLOCK_SIZE") or (1 << 27))
        step = max(256, min(limit // per_item_bytes, 1 << 30) // 256 * 256)
        return [(a, min(a + step, n_items)) for a in range(0, n_items, step)]

    def _dispatch_rays(self, defines: dict, rays_buf, n_items: int, rays_per_item: int, extra=None):
        cs = self.gpu.compute(self.shader("trace.glsl"), {**self.cdi_defines(), **defines})
        self.bind_cdi(cs)
        if extra:
            extra(cs)
        hits = self._out["t"]
        for a, b in self._chunks(n_items, RAY_BYTES * rays_per_item):
            k = rays_per_item
            rays_buf.bind_to_storage_buffer(B.RAYS, offset=a * k * RAY_BYTES, size=(b - a) * k * RAY_BYTES)
            hits.bind_to_storage_buffer(B.HITS, offset=a * k * 4, size=(b - a) * k * 4)
            if "ranges" in self._out:
                self._out["ranges"].bind_to_storage_buffer(B.VPL_RANGES, offset=a * 4, size=(b - a) * 4)
            cs["n_items"].value = b - a
            cs.run(min(-(-(b - a) // 64), MAX_GROUPS))
        self.gpu.ctx.memory_barrier()

    def _vpl_range(self, effect, batch):
        if batch is None:
            raise LdbenchError("method 'cdi-vpl': the vpl_range effect needs its VPL batch")
        p, gpu, n = self.params, self.gpu, len(batch)
        nr = len(batch.rays)
        self._buffer("ranges", 4 * n)
        self._buffer("t", 4 * nr)
        if p.vpl.range == "cdi":
            if p.cdi == "static":
                self._release_geometry()
            self._build_cdi()
            with gpu.stage("raycast"):
                def extra(cs):
                    cs["cap"].value = float(batch.cap)
                    cs["range_max"].value = int(batch.mode == "max")
                self._dispatch_rays({"CDI_VPL": 1}, batch.upload(gpu), n, 6, extra)
        elif p.vpl.range == "random":
            if p.cdi == "static":
                self._release_geometry()
            diag = self.scene.diagonal()
            cs = gpu.compute(self.shader("trace.glsl"), {"CDI_RANDOM": 1})
            with gpu.stage("random_range"):
                cs["n_items"].value = n
                cs["seed"].value = int(batch.seed) & 0xFFFFFFFF
                cs["r_min"].value = p.vpl.r_min * diag
                cs["r_max"].value = p.vpl.r_max * diag
                self._out["ranges"].bind_to_storage_buffer(B.VPL_RANGES)
                cs.run(min(-(-n // 64), MAX_GROUPS))
                gpu.ctx.memory_barrier()
        else:  # exact: Mitsuba once per batch (untimed), then a copy per frame
            if self._exact_cache is None or self._exact_cache[0] is not batch:
                t = np.asarray(self.exact_distances(self.scene, batch.rays), np.float32)
                self._exact_cache = (batch, self.res.buffer("out.exact", reduce_ranges(t, batch.cap, batch.mode)),
                                     self.res.buffer("out.exact_t", t))
            with gpu.stage("exact_range"):
                _, rng, tt = self._exact_cache
                gpu.ctx.copy_buffer(self._out["ranges"], rng)
                gpu.ctx.copy_buffer(self._out["t"], tt)
        ranges, t = self._out["ranges"], self._out["t"]
        has_t = p.vpl.range != "random"
        arrays = {"range": lambda: np.frombuffer(self.gpu.read(ranges, 4 * n), np.float32).copy()}
        if has_t:
            arrays["t"] = lambda: np.frombuffer(self.gpu.read(t, 4 * nr), np.float32).copy()
        return Result(arrays=arrays, memory_bytes=self.res.by_buffer(), counters=self._counters,
                      invariants=self._invariants)

    def _rays(self, batch):
        if batch is None:
            raise LdbenchError("method 'cdi-vpl': the rays effect needs its ray batch")
        p, n = self.params, len(batch)
        self._cdi()
        if p.cdi == "static":
            self._release_geometry()
        self._build_cdi()
        self._out.pop("ranges", None)
        self._buffer("t", 4 * n)
        with self.gpu.stage("trace"):
            self._dispatch_rays({"CDI_RAYS": 1}, batch.upload(self.gpu), n, 1)
        t = self._out["t"]
        return Result(arrays={"t": lambda: np.frombuffer(self.gpu.read(t, 4 * n), np.float32).copy()},
                      memory_bytes=self.res.by_buffer(), counters=self._counters, invariants=self._invariants)

    def _indirect(self, view):
        if self._geometry_released:
            raise LdbenchError("method 'cdi-vpl': a static CDI that answered rays no longer holds the scene")
        if self.lighting is None:
            self.lighting = VplLighting(self, self.scene)
        if self.params.vpl.range == "cdi":
            self._build_cdi()
        with self.gpu.stage("gbuffer"):
            self.gbuf.render(view)
        image = self.lighting.frame(view)
        light = self.lighting
        return Result(image=image, mask=self.gbuf.mask, memory_bytes=self.res.by_buffer(),
                      counters=lambda: {**self._counters(), **light.counters()},
                      invariants=lambda c: self._invariants(c) + light.invariants(c))

    # ---- counters and invariants ---------------------------------------------------------------------
    def _uses_cdi(self) -> bool:
        return self.cdi_struct is not None

    def _counters(self) -> dict:
        p = self.params
        c = {"directions": p.directions, "resolution": p.resolution, "build": p.structure.source,
             "texel_world": self.texel, "bounding_radius": self.radius}
        if self._uses_cdi():
            c.update(self.cdi_struct.stats())
            c["cdi_bytes"] = int(sum(self.cdi_struct.memory().values()))
            c["cdi_mb"] = c["cdi_bytes"] / 2**20
        return c

    def _invariants(self, c: dict) -> list:
        return layered_invariants(self.cdi_struct, c) if self._uses_cdi() else []

    def release(self):
        self.lighting = None
        self._out.clear()
        self._exact_cache = None
        super().release()
