"""``ldm-ao``: ambient occlusion / obscurance traced through N orthographic layered depth maps (aalund2015).

Per frame (stages):

``gbuffer``  camera G-buffer (position, camera-facing geometric normal).
``count``    (only ``pool = "count"``) counting pass over all maps: the exact node count, pool (re)allocated.
``build``    one instanced draw rasterizes the scene into all N maps (both faces, no depth test), every
             fragment inserted into its texel's linked list (:mod:`methods.linked_list`), pre-sorted by a
             lock-free CAS insert (``sorted_insert = True``, the paper's PSPPSLL).
``sort``     (``sorted_insert = False``) yang2010 unsorted lists sorted in place by a compute pass.
``ao``       compute pass over the G-buffer pixels, looping over the N maps.

Maps. The N axes are :func:`methods.directions.ldm_axes` (the recursive zonal equal-area partition of the
upper hemisphere; {±v_i} is an antipodally symmetric equal-area set of 2N directions). Map i is an
orthographic ``resolution²`` view along v_i that covers the scene's bounding sphere (centre = bounds
centre, radius = farthest vertex), so every map sees all geometry; stored depth = (p − c)·v_i.

Trace (aalund2015 §3.1, ``methods/glsl/ldm_trace.glsl``): project x into map i, walk the sorted list to
x's depth; along +v_i the first hit is the next entry beyond x, along −v_i the previous one. The
surface x itself is in the list: entries closer than the receiver plane's crossing of the texel's
column, plus ``bias`` texels, are skipped (see the GLSL).

AO (aalund2015 eq. 2 with DESIGN.md's definition): for the camera-facing normal n, each map gives the
direction d_i = sign(n·v_i) v_i, cos θ_i = |n·v_i|, V_i = 1 − ρ(t_i) with the effect's fall-off (no hit:
V = 1). ``estimator = "ratio"`` (default) returns Σ V_i cos θ_i / Σ cos θ_i, exact for an unoccluded
point and consistent as N → ∞; ``"paper"`` returns eq. (2), (2/N) Σ V_i cos θ_i. Background pixels = 1.

======================  ========  =======  ========================================================
Parameter               Default   Paper    Meaning
======================  ========  =======  ========================================================
``directions``          128       512      number of LDMs (axes; each answers ±v)
``resolution``          128       200, 50  texels per side of each LDM
``bias``                0.25               self-intersection bias along the ray, in LDM texels
``pool``                grow               node-pool sizing: grow | count | fixed (methods/linked_list.py)
``pool_capacity``       0                  nodes for ``fixed`` (and first size for ``grow``)
``sorted_insert``       True      True     lock-free sorted insert; False = yang2010 + sort pass
``max_list``            64                 local-array length of the sort pass (longer: slow path)
``instanced``           True               one instanced draw for all maps (False: a draw per map)
``aggregate_atomics``   False              one atomicAdd per subgroup on the node counter (ARB_shader_ballot)
``indexed``             True               build from indexed position-only geometry (vertex reuse)
``estimator``           ratio     paper    ratio = Σ V cos / Σ cos; paper = (2/N) Σ V cos
======================  ========  =======  ========================================================
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from harness.gpu import read_texture
from methods.base import Method, ParamsBase, Result, param
from methods.directions import ldm_axes, orthonormal_basis
from methods.linked_list import POLICIES, LayeredLinkedLists

B_AXES = 11
FAR = 3.0e38


def bounding_sphere(scene) -> tuple[np.ndarray, float]:
    """(centre, radius): the bounds' centre and the distance to the farthest vertex (float64)."""
    v, _, _, _ = scene.merged()
    lo, hi = scene.bounds()
    c = 0.5 * (lo + hi)
    r = float(np.sqrt(((v.astype(np.float64) - c) ** 2).sum(1).max()))
    return c, max(r, 1e-6)


def ldm_layers(axes: np.ndarray, centre: np.ndarray, radius: float):
    """Per-map clip matrices (N, 4, 4), depth rows (N, 4) and the (u, w, v) basis of each axis."""
    axes = np.asarray(axes, np.float64)
    u, w = orthonormal_basis(axes)
    n = len(axes)
    clip = np.zeros((n, 4, 4))
    zs = 1.0 / (radius * 1.01)  # depth range inside the clip volume with a margin
    for row, vec, s in ((0, u, 1.0 / radius), (1, w, 1.0 / radius), (2, axes, zs)):
        clip[:, row, :3] = vec * s
        clip[:, row, 3] = -(vec @ centre) * s
    clip[:, 3, 3] = 1.0
    rows = np.concatenate([axes, -(axes @ centre)[:, None]], axis=1)
    return clip, rows, (u, w, axes)


@dataclass(frozen=True)
class LdmAOParams(ParamsBase):
    directions: int = param(128, "number of LDMs (axes; each answers +v and -v)", lo=1, hi=4096, paper=512)
    resolution: int = param(128, "texels per side of each LDM", lo=4, hi=4096, paper="200 (Fig. 8), 50 (Fig. 9)")
    bias: float = param(0.25, "self-intersection bias along the ray, in LDM texels", lo=0.0, hi=64.0)
    pool: str = param("grow", "node-pool sizing: grow and redo / counting pass / fixed", choices=POLICIES)
    pool_capacity: int = param(0, "nodes for pool=fixed (first size for grow; 0 = 1 per texel)", lo=0)
    sorted_insert: bool = param(True, "lock-free sorted insert (PSPPSLL); False = yang2010 insert + sort pass",
                                paper=True)
    max_list: int = param(64, "local-array length of the sort pass (longer lists take a slow exact path)",
                          lo=1, hi=1024)
    instanced: bool = param(True, "one instanced draw for all maps (False: one draw per map)")
    aggregate_atomics: bool = param(False, "warp-aggregated atomicAdd on the node counter (ARB_shader_ballot)")
    indexed: bool = param(True, "build from indexed position-only geometry (else the triangle list)")
    estimator: str = param("ratio", "ratio = sum V cos / sum cos; paper = 2/N sum V cos (eq. 2)",
                           choices=("ratio", "paper"), paper="paper")


class LdmAO(Method):
    """Ambient occlusion / obscurance through N layered depth maps (aalund2015 §3.3, §4.1)."""

    name = "ldm-ao"
    paper = "aalund2015"
    effects = frozenset({"ao"})
    Params = LdmAOParams

    def setup(self, gpu, scene):
        p = self.params
        self.setup_scene(gpu, scene)
        self.centre, self.radius = bounding_sphere(scene)
        axes = ldm_axes(p.directions)
        clip, rows, (u, w, v) = ldm_layers(axes, self.centre, self.radius)
        self.ll = LayeredLinkedLists(gpu, self.geo, self.res, layers=p.directions, width=p.resolution,
                                     sorted_insert=p.sorted_insert, pool=p.pool,
                                     pool_capacity=p.pool_capacity, max_list=p.max_list,
                                     instanced=p.instanced, aggregate=p.aggregate_atomics, indexed=p.indexed,
                                     prefix="ldm.")
        self.ll.set_layers(clip, rows)
        basis = np.zeros((p.directions, 3, 4), np.float32)
        basis[:, 0, :3], basis[:, 1, :3], basis[:, 2, :3] = u, w, v
        self.axes_buf = self.res.buffer("ldm.axes", basis)
        self.texel = 2.0 * self.radius / p.resolution
        self.out = None
        self._out_size = None

    def _ao_program(self):
        return self.gpu.compute(self.shader("ao.glsl"), self.ll.defines())

    def frame(self, view, effect):
        p, gpu = self.params, self.gpu
        with gpu.stage("gbuffer"):
            self.gbuf.render(view)
        self.ll.build()
        w, h = view.width, view.height
        if self._out_size != (w, h):
            self.out = self.res.texture("output", (w, h), 1, "f4")
            self._out_size = (w, h)
        cs = self._ao_program()
        cs["g_position"].value = 0
        cs["g_normal"].value = 1
        cs["n_maps"].value = p.directions
        cs["bias"].value = p.bias * self.texel
        cs["d_max"].value = FAR if math.isinf(effect.d_max) else float(effect.d_max)
        cs["falloff"].value = 0 if effect.falloff == "step" else 1
        cs["estimator"].value = 0 if p.estimator == "ratio" else 1
        cs["ldm_centre"].value = tuple(float(x) for x in self.centre)
        cs["ldm_radius"].value = float(self.radius)
        cs["ldm_size"].value = (p.resolution, p.resolution)
        with gpu.stage("ao"):
            self.gbuf.bind(0)
            self.ll.bind()
            self.axes_buf.bind_to_storage_buffer(B_AXES)
            self.out.bind_to_image(0, read=False, write=True)
            cs.run((w + 7) // 8, (h + 7) // 8)
        out = self.out
        return Result(image=lambda: read_texture(out, 1), mask=self.gbuf.mask,
                      memory_bytes=self.res.by_buffer(), counters=self._counters)

    def _counters(self) -> dict:
        c = self.ll.stats()
        c.update(directions=self.params.directions, resolution=self.params.resolution,
                 texel_world=self.texel, bounding_radius=self.radius)
        return c

