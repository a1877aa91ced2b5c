"""``ldm``: rays traced through N orthographic layered depth maps (aalund2015); effects ``ao``, ``rays`` and
``indirect``.

Also registered as ``ldm-ao`` (its earlier name): suites and command lines using it keep working.

Per frame (stages):

``gbuffer``  (``ao``) camera G-buffer (position, camera-facing geometric normal).
build        the N maps as a layered structure (:mod:`ldbench.methods.structures`), ``layout = "linked"``: one
             instanced draw rasterizes the scene into all maps (both faces, no depth test), every fragment
             inserted into its texel's linked list (:mod:`ldbench.methods.structures.linked`), pre-sorted by a lock-free
             CAS insert (``sorted_insert = True``, the paper's PSPPSLL) — stages ``count`` (only
             ``pool = "count"``), ``build``, ``sort`` (only ``sorted_insert = False``);
             ``layout = "linear"``: linearised arrays (:mod:`ldbench.methods.structures.linear`) — stages ``count``,
             ``scan``, ``fill``, ``sort``. Both give the same sorted lists, hence the same images.
``ao``       compute pass over the G-buffer pixels, looping over the N maps.
``trace``    (``rays``) one invocation per ray of the harness's batch: the map whose axis is nearest to the
             ray answers it with the same two-way query, along ±v_k (the method's approximation of the
             direction). A ray into the surface it starts on (n·d < 0) hits it at t = 0.
indirect     (``indirect``, §3.4, §4.2) ``gbuffer``, the build, then ``light_raster``, ``trace`` (photons:
             first hit by rasterizing from the spot light, split into the N map directions, second hit by
             the two-way query, camera visibility, photon differentials) and ``splat`` (Silverman's kernel
             over each photon's footprint): :mod:`ldbench.methods.ldm.indirect`, docs/reference/methods/ldm_indirect.md.

Maps. The N axes are :func:`ldbench.methods.directions.ldm_axes` (the recursive zonal equal-area partition of the
upper hemisphere; {±v_i} is an antipodally symmetric equal-area set of 2N directions). Map i is an
orthographic ``resolution²`` view along v_i that covers the scene's bounding sphere (centre = bounds
centre, radius = farthest vertex), so every map sees all geometry; stored depth = (p − c)·v_i.

Trace (aalund2015 §3.1, ``ldbench/methods/ldm/ldm_trace.glsl``): project x into map i, walk the sorted list to
x's depth; along +v_i the first hit is the next entry beyond x, along −v_i the previous one. The
surface x itself is in the list: entries closer than the receiver plane's crossing of the texel's
column, plus ``bias`` texels, are skipped (see the GLSL).

AO (aalund2015 eq. 2 with docs/design.md's definition): for the camera-facing normal n, each map gives the
direction d_i = sign(n·v_i) v_i, cos θ_i = |n·v_i|, V_i = 1 − ρ(t_i) with the effect's fall-off (no hit:
V = 1). ``estimator = "ratio"`` (default) returns Σ V_i cos θ_i / Σ cos θ_i, exact for an unoccluded
point and consistent as N → ∞; ``"paper"`` returns eq. (2), (2/N) Σ V_i cos θ_i. Background pixels = 1.

Defaults are the fastest build that stores the same lists (the compute splat, yang2010's insert, the lists
sorted by the long triangles' tiles and a sort pass of the longer ones, no read-back: docs/reference/methods/fast_builds.md) and
the AO's batches of maps in one dispatch (the same image to float rounding); ``preset = "paper"`` is the
paper's build (hardware raster, pre-sorted lock-free insert), which every ``reproduce`` entry runs; both
render the same images.

Parameters (``ldbench methods ldm``, docs/reference/parameters.md) are grouped by role (the earlier flat names,
e.g. ``build``, ``photons``, still work: :attr:`LdmParams.renamed`): ``structure.*`` the maps' layered structure
(:class:`~ldbench.methods.structures.spec.StructureSpec`), ``trace.*`` the map query of every effect,
``rays.*`` and ``indirect.*`` one effect's.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ldbench.core.bindings import B
from ldbench.core.errors import LdbenchError
from ldbench.core.gpu import read_texture
from ldbench.core.params import ParamsBase, Preset, group, param
from ldbench.methods.base import Method, Result
from ldbench.methods.gbuffer import gbuffer_param
from ldbench.methods.directions import ldm_axes, nearest_axis_table
from ldbench.methods.invariants import layered_invariants
from ldbench.methods.structures import (StructureSpec, bind_ortho_layers, bounding_sphere, make_structure,
                                        ortho_layers)
from ldbench.methods.scan import groups_2d

from .indirect import IndirectLight

# Heavy: scipy.spatial is imported by one_way_axis_table() alone, the one function that needs it.

LUT_RES = 128
FAR = 3.0e38


ONE_WAY_SLOTS = 12  # candidates per cell of the one-way table (3 uvec4): the 9 samples never need more


def one_way_axis_table(axes: np.ndarray, res: int = LUT_RES) -> np.ndarray:
    """Candidate nearest +v_k (largest signed d·v: ``trace.query = one_way``) per cell of the full cube:
    (6·res², :data:`ONE_WAY_SLOTS`) uint32, unused slots 0xFFFFFFFF. Row of d: face 2a + (d_a < 0) of its
    dominant axis a, cell of (d_{a+1}, d_{a+2}) / |d_a| (``ldm_one_way_row`` in ldbench/methods/ldm/ldm_trace.glsl).
    As :func:`~ldbench.methods.directions.nearest_axis_table`: each cell lists the nearest axes of a 3 × 3
    grid of directions over it, so a lookup finds the true nearest unless a sliver of its Voronoi cell
    holds none of the samples (then the second nearest)."""
    from scipy.spatial import cKDTree

    axes = np.asarray(axes, np.float64).reshape(-1, 3)
    r = int(res)
    t = np.arange(r + 1) / r * 2.0 - 1.0
    grid = [t[:-1], (t[:-1] + t[1:]) * 0.5, t[1:]]
    tree = cKDTree(axes)  # on the unit sphere, nearest = largest d·v
    out = np.full((6 * r * r, ONE_WAY_SLOTS), 0xFFFFFFFF, np.uint32)
    for a in range(3):
        for s in (1.0, -1.0):
            best = []
            for gi in grid:
                for gj in grid:
                    P, Q = np.meshgrid(gi, gj, indexing="ij")
                    d = np.zeros((r * r, 3))
                    d[:, a], d[:, (a + 1) % 3], d[:, (a + 2) % 3] = s, P.reshape(-1), Q.reshape(-1)
                    best.append(tree.query(d / np.linalg.norm(d, axis=1, keepdims=True))[1])
            b = np.sort(np.stack(best, 1), 1)
            first = np.concatenate([np.ones((len(b), 1), bool), b[:, 1:] != b[:, :-1]], 1)
            rank = np.cumsum(first, 1) - 1
            rows, cols = np.nonzero(first)
            face = 2 * a + (s < 0)
            out[face * r * r + rows, rank[rows, cols]] = b[rows, cols]
    return out


@dataclass(frozen=True)
class LdmTrace(ParamsBase):
    """The map query every effect traces with (``trace.``)."""

    prefix = "trace."
    bias: float = param(0.25, "self-intersection bias along the ray, in LDM texels", lo=0.0, hi=64.0)
    crease: float = param(0.5, "crease window behind the point, in LDM texels (0 = plain skip rule; "
                          "ldbench/methods/ldm/ldm_trace.glsl)",
                          lo=0.0, hi=64.0, paper=0)
    estimator: str = param("ratio", "ratio = sum V cos / sum cos; paper = 2/N sum V cos (eq. 2); for the "
                           "photon split: weights cos / sum cos or 2 cos / N", choices=("ratio", "paper"),
                           paper="paper")
    query: str = param("two_way", "two_way: N maps, each answering +v and -v from one walk; one_way: 2N maps "
                       "along +v and -v, each answering its own axis (the same 2N directions; ao and rays)",
                       choices=("two_way", "one_way"), paper="two_way")
    walk: str = param("early_stop", "(ao, rays) early_stop: the list walk ends at x's depth (§4.1, pre-sorted "
                      "lists); full: the whole list, nearest entry kept (as for unsorted lists; the same answers)",
                      choices=("early_stop", "full"), paper="early_stop")
    prefetch: int = param(1, "(ao) maps whose first list node is loaded before any of them is walked (1: one "
                          "map at a time; the same image)", lo=1, hi=16)
    map_batch: int = param(64, "(ao) maps per batch: a dispatch each, or a z-slice of one dispatch "
                           "(map_schedule); 0: all maps in one batch", lo=0, hi=1 << 16)
    map_schedule: str = param("grid", "(ao) the batches of map_batch maps: one dispatch each, or one "
                              "dispatch of all (batch = workgroup z) whose partial sums a pass over the pixels "
                              "adds in batch order (the same image to float rounding; dispatches where the "
                              "partial sums would pass the driver's largest buffer)",
                              choices=("dispatches", "grid"))

    def defines(self) -> dict:
        """The GLSL defines of the query and walk modes (ldbench/methods/ldm/ldm_trace.glsl) and of the AO pass."""
        return {**({"LDM_ONE_WAY": 1} if self.query == "one_way" else {}),
                **({"LDM_FULL_WALK": 1} if self.walk == "full" else {}),
                **({"LDM_PREFETCH": self.prefetch} if self.prefetch > 1 else {})}

    def map_batches(self, n_maps: int) -> list:
        """The AO pass's batches of maps: ``[(k_begin, k_end), ...]`` over the ``n_maps`` maps."""
        m = self.map_batch if 0 < self.map_batch < n_maps else n_maps
        return [(k, min(k + m, n_maps)) for k in range(0, n_maps, m)]


@dataclass(frozen=True)
class LdmRays(ParamsBase):
    """The ``rays`` effect (``rays.``)."""

    prefix = "rays."
    map_lookup: str = param("table", "how a ray finds the map whose axis is nearest to it: table (a 3 x 128^2 "
                            "cube table of up to 4 candidates, ldbench/methods/directions.py: the true nearest for all "
                            "but about 1e-5 of directions, else the second nearest) or scan (all N axes)",
                            choices=("table", "scan"))


@dataclass(frozen=True)
class LdmIndirect(ParamsBase):
    """The ``indirect`` effect: photons and their splats (``indirect.``)."""

    prefix = "indirect."
    photons: int = param(128, "light raster side R (one photon per texel inside the spot cone)",
                         lo=4, hi=4096, paper="not published (the author's engine: 100)")
    footprint_scale: float = param(2.0, "multiplies the photon differentials before splatting",
                                   lo=1e-3, hi=1e4, paper="engine: 2000 per far-plane unit, about 24 light texels")
    differential_bias: float = param(1.0, "a photon whose positional differential has a component above this "
                                     "fraction of the scene's bounding radius is dropped", lo=0.0,
                                     paper="engine: 0.5 (two-pass) / 10 (atomic) model units")
    max_splat_px: float = param(400.0, "largest splat kept, screen-rectangle diagonal in pixels",
                                lo=1.0, paper="engine (atomic variant): 400")
    topology_bias: float = param(1.0, "the paper's a (eq. 7); an offset along the normal of one footprint "
                                 "size / a leaves the kernel", lo=0.0, paper="engine: a = footprint scale")
    visibility_bias: float = param(2.0, "a second hit is visible when it lies within this many LDM texels of "
                                   "the camera pixel's tangent plane", lo=0.0)
    refine_hit: bool = param(True, "move the second hit along the ray onto the tangent plane of the camera "
                             "pixel that sees it (False: the map's texel-centre depth, as the paper)",
                             paper=False)
    rotation: str = param("incident", "the diffuse reflection of the directional differential, alpha(w_i, d2) "
                          "with w_i = -d1 (incident: pointing back to the light, as the author's engine; keeps a "
                          "diverging beam diverging) or w_i = d1 (propagation: d* = alpha d alpha-bar taking d1 "
                          "to d2)", choices=("incident", "propagation"),
                          paper="w_i 'the incoming direction' (engine: incident)")
    splat: str = param("atomic", "additive blending of rasterized quads, or float atomics over the same pixels "
                       "in a compute pass", choices=("blend", "atomic"), paper="blend")


#: the structure fields ``ldm`` lets a suite choose (the LDMs are orthographic: every source applies)
LDM_STRUCTURE = ("layout", "source", "assembly", "pool", "pool_capacity", "sorted_insert", "max_list",
                 "instanced", "aggregate", "indexed", "splat_large", "splat_batch", "splat_group", "splat_queue",
                 "splat_sort")


@dataclass(frozen=True)
class LdmParams(ParamsBase):
    directions: int = param(128, "number of LDMs (axes; each answers +v and -v)", lo=1, hi=4096, paper=512)
    resolution: int = param(128, "texels per side of each LDM", lo=4, hi=4096, paper="200 (Fig. 8), 50 (Fig. 9)")
    gbuffer: str = gbuffer_param()
    structure: StructureSpec = group(StructureSpec, "the N maps as one layered structure", expose=LDM_STRUCTURE,
                                     choices={"source": ("raster", "one_pass", "splat")},
                                     paper={"layout": "linked", "source": "raster", "sorted_insert": True},
                                     source="splat", sorted_insert=False, pool="lazy", aggregate=True,
                                     splat_queue=True, splat_batch=16, splat_group=128, splat_sort=True)
    trace: LdmTrace = group(LdmTrace, "the two-way map query of every effect")
    rays: LdmRays = group(LdmRays, "the rays effect: how a ray picks its map")
    indirect: LdmIndirect = group(LdmIndirect, "effect indirect (photons with differentials)")

    presets = {"paper": Preset(
        "the paper's build (hardware raster of every map, lock-free pre-sorted insert; the pool sized by a "
        "read-back), splats blended by the raster and the AO in one dispatch over all maps; the default stores "
        "the same lists (a compute raster with the hardware's fill rule, yang2010's insert and a sort pass, no "
        "read-back), so the same AO and rays, "
        "and adds the same splats over the same pixels with float atomics (the indirect image to the order "
        "of the sums, docs/reference/methods/fast_builds.md)",
        {"structure.layout": "linked", "structure.source": "raster", "structure.sorted_insert": True,
         "structure.pool": "grow", "structure.aggregate": False, "indirect.splat": "blend",
         "trace.map_batch": 0})}

    renamed = {"layout": "structure.layout", "build": "structure.source", "assembly": "structure.assembly",
               "pool": "structure.pool", "pool_capacity": "structure.pool_capacity",
               "sorted_insert": "structure.sorted_insert", "max_list": "structure.max_list",
               "instanced": "structure.instanced", "aggregate_atomics": "structure.aggregate",
               "indexed": "structure.indexed", "bias": "trace.bias", "crease": "trace.crease",
               "estimator": "trace.estimator", "map_lookup": "rays.map_lookup",
               **{k: f"indirect.{k}" for k in ("photons", "footprint_scale", "differential_bias", "max_splat_px",
                                               "topology_bias", "visibility_bias", "refine_hit", "rotation",
                                               "splat")}}


class Ldm(Method):
    """Rays through N layered depth maps (aalund2015 §3): AO / obscurance (§3.3, §4.1), ray queries and
    single-bounce indirect light with photon differentials (§3.4, §4.2)."""

    name = "ldm"
    aliases = ("ldm-ao",)
    paper = "aalund2015"
    effects = frozenset({"ao", "rays", "indirect"})
    Params = LdmParams
    params: LdmParams

    def setup(self, gpu, scene):
        p = self.params
        self.setup_scene(gpu, scene, gbuffer=p.gbuffer)
        self.centre, self.radius = bounding_sphere(scene)
        axes = self._axes()
        self.n_maps = len(axes)
        clip, rows, (u, w, v) = ortho_layers(axes, self.centre, self.radius)
        self.ls = make_structure(p.structure, gpu, self.geo, self.res, layers=self.n_maps, width=p.resolution,
                                 prefix="ldm.")
        self.ls.set_layers(clip, rows)
        basis = np.zeros((self.n_maps, 3, 4), np.float32)
        basis[:, 0, :3], basis[:, 1, :3], basis[:, 2, :3] = u, w, v
        self.axes_buf = self.res.buffer("ldm.axes", basis)
        self.lut_buf = None  # built by the first `rays` frame, outside its stages (CPU, < 1 s)
        self.texel = 2.0 * self.radius / p.resolution
        self.out = None
        self._out_size = self._sums_n = None
        self._batch = None
        self.indirect = None

    def _axes(self) -> np.ndarray:
        """The maps' axes: N two-way maps along v_i, each answering +v_i and -v_i; with ``trace.query =
        one_way``, 2N one-way maps along +v_i and -v_i, each answering its own axis: the same 2N directions
        from twice the maps."""
        axes = ldm_axes(self.params.directions)
        return np.concatenate([axes, -axes]) if self.params.trace.query == "one_way" else axes

    def _bind_maps(self, cs):
        p = self.params
        for name, v in (("n_maps", self.n_maps), ("bias", p.trace.bias * self.texel),
                        ("ldm_crease", p.trace.crease * self.texel)):
            if name in cs:  # a statistics variant may not use all of them
                cs[name].value = v
        self.ls.bind()
        bind_ortho_layers(cs, self.axes_buf, self.centre, self.radius, p.resolution)
        if self.lut_buf is not None and "ldm_lut_res" in cs:
            cs["ldm_lut_res"].value = LUT_RES
            self.lut_buf.bind_to_storage_buffer(B.LDM_LUT)

    def frame(self, view, effect, inputs=None):
        if effect.name == "rays":
            return self._rays(inputs)
        if effect.name == "indirect":
            return self._indirect(view)
        p, gpu = self.params, self.gpu
        with gpu.stage("gbuffer"):
            self.gbuf.render(view)
        self.ls.build()
        w, h = view.width, view.height
        if self._out_size != (w, h):
            self.out = self.res.texture("output", (w, h), 1, "f4")
            self._out_size = (w, h)
        batches = p.trace.map_batches(self.n_maps)
        batched = len(batches) > 1
        grid = (batched and p.trace.map_schedule == "grid"
                and 8 * w * h * len(batches) <= self.ls.ssbo_limit and w * h * len(batches) < 1 << 32)
        mode = {"LDM_AO_GRID": 1} if grid else {"LDM_MAP_BATCH": 1} if batched else {}
        defines = {**self.ls.defines(), **p.trace.defines()}
        passes = [self.gpu.compute(self.shader("ao.glsl"), {**defines, **mode})]
        if grid:
            passes.append(self.gpu.compute(self.shader("ao.glsl"), {**defines, "LDM_AO_COMBINE": 1}))
        n_sums = w * h * (len(batches) if grid else 1)
        if batched and self._sums_n != n_sums:
            self.ao_sums = self.res.buffer("ldm.ao_sums", reserve=8 * n_sums)
            self._sums_n = n_sums
        for cs in passes:
            for name, v in (("g_position", 0), ("g_normal", 1), ("falloff", int(effect.falloff != "step")),
                            ("d_max", FAR if math.isinf(effect.d_max) else float(effect.d_max)),
                            ("estimator", int(p.trace.estimator != "ratio")), ("n_maps", self.n_maps),
                            ("map_batch", batches[0][1])):
                if name in cs:
                    cs[name].value = v
        cs = passes[0]
        with gpu.stage("ao"):
            self.gbuf.bind(0)
            self._bind_maps(cs)
            self.out.bind_to_image(B.OUT_IMAGE, read=False, write=True)
            if batched:
                self.ao_sums.bind_to_storage_buffer(B.LDM_AO_SUMS)
            if grid:  # the partial sums, then the pass adding them
                cs.run((w + 7) // 8, (h + 7) // 8, len(batches))
                gpu.ctx.memory_barrier()
                passes[1].run((w + 7) // 8, (h + 7) // 8)
                gpu.ctx.memory_barrier()
            else:
                for k0, k1 in batches:
                    if batched:
                        cs["k_begin"].value, cs["k_end"].value = k0, k1
                    cs.run((w + 7) // 8, (h + 7) // 8)
                    gpu.ctx.memory_barrier()  # the sums for the next batch; the image for the read-back
        out = self.out
        return Result(image=lambda: read_texture(out, 1), mask=self.gbuf.mask,
                      memory_bytes=self.res.by_buffer(), counters=self._counters,
                      invariants=lambda c: layered_invariants(self.ls, c))

    def _rays_defines(self) -> dict:
        p = self.params
        if p.rays.map_lookup == "table" and self.lut_buf is None:
            axes = self._axes()
            table = (nearest_axis_table(axes, LUT_RES) if p.trace.query == "two_way"
                     else one_way_axis_table(axes, LUT_RES))
            self.lut_buf = self.res.buffer("ldm.map_table", table)
        return {**self.ls.defines(), **self.params.trace.defines(),
                **({"LDM_LUT": 1} if self.lut_buf is not None else {})}

    def _rays(self, batch):
        if batch is None:
            raise LdbenchError("method 'ldm': the rays effect needs its ray batch")
        self._ao_only()
        gpu, n = self.gpu, len(batch)
        self.ls.build()
        if getattr(self, "_hits_n", None) != n:
            self.hits = self.res.buffer("ldm.ray_hits", reserve=4 * n)
            self._hits_n = n
        cs = gpu.compute(self.shader("trace_rays.glsl"), self._rays_defines())
        cs["n_rays"].value = n
        with gpu.stage("trace"):
            self._bind_maps(cs)
            batch.upload(gpu).bind_to_storage_buffer(B.RAYS)
            self.hits.bind_to_storage_buffer(B.HITS)
            cs.run(*groups_2d(-(-n // 64)))
            gpu.ctx.memory_barrier()
        self._batch = batch
        hits = self.hits
        return Result(arrays={"t": lambda: np.frombuffer(self.gpu.read(hits), np.float32).copy()},
                      memory_bytes=self.res.by_buffer(), counters=self._counters,
                      invariants=lambda c: layered_invariants(self.ls, c))

    def _ao_only(self):
        if self.params.trace.prefetch != 1:  # map_batch, a dispatch size, has nothing to change here
            raise LdbenchError("method 'ldm': trace.prefetch applies to the ao effect only")

    def _indirect(self, view):
        t = self.params.trace
        if (t.query, t.walk) != ("two_way", "early_stop"):
            raise LdbenchError("method 'ldm': trace.query and trace.walk apply to the ao and rays effects only "
                               "(the photon split traces both directions of every map)")
        self._ao_only()
        if self.indirect is None:
            self.indirect = IndirectLight(self)
        with self.gpu.stage("gbuffer"):
            self.gbuf.render(view)
        self.ls.build()
        ind = self.indirect
        image = ind.frame(view)
        return Result(image=image, mask=self.gbuf.mask, memory_bytes={**self.res.by_buffer(), **ind.memory()},
                      counters=lambda: {**self._counters(), **ind.counters()},
                      invariants=lambda c: layered_invariants(self.ls, c) + ind.invariants(c))

    def release(self):
        if self.indirect is not None:
            self.indirect.release()
            self.indirect = None
        super().release()

    def _mean_ray_angle(self) -> float:
        """Mean angle (degrees) between the batch's rays and their maps' axes: an untimed dispatch."""
        batch, n = self._batch, len(self._batch)
        angle = self.gpu.ctx.buffer(reserve=4 * n)
        try:
            cs = self.gpu.compute(self.shader("trace_rays.glsl"), {**self._rays_defines(), "LDM_ANGLE_STATS": 1})
            cs["n_rays"].value = n
            self._bind_maps(cs)
            batch.upload(self.gpu).bind_to_storage_buffer(B.RAYS)
            self.hits.bind_to_storage_buffer(B.HITS)
            angle.bind_to_storage_buffer(B.LDM_ANGLE)
            cs.run(*groups_2d(-(-n // 64)))
            self.gpu.ctx.memory_barrier()
            return float(np.frombuffer(self.gpu.read(angle), np.float32).mean())
        finally:
            angle.release()

    def _counters(self) -> dict:
        c = self.ls.stats()
        c.update(directions=self.params.directions, maps=self.n_maps, resolution=self.params.resolution,
                 texel_world=self.texel, bounding_radius=self.radius)
        if self._batch is not None:
            c["mean_ray_map_angle_deg"] = self._mean_ray_angle()
        return c
