"""The base of every layout: the layers' transforms, the counters, the fragment pass and the invariants.

:class:`LayeredStructure` holds what every layout shares (``layers`` images of ``width × height`` texels,
the per-layer clip transform and depth row, the counters buffer) and runs one *fragment pass* through its
fragment source (:mod:`ldbench.methods.structures.sources`, :mod:`ldbench.methods.structures.splat`), which stores every
fragment with ``ls_store`` of ``ldbench/methods/glsl/layered/store.glsl``. The layouts
(:mod:`ldbench.methods.structures.linked`, :mod:`ldbench.methods.structures.linear`) implement the build around it.

Each layer ``k`` has a clip transform ``clip[k]`` (world → clip) and a depth row ``depth_row[k]``; the
stored depth is ``dot(depth_row, (p, 1))`` of the fragment's world position (interpolated
perspective-correctly, so any depth linear in world space is exact).

**Payload** words per node (``spec.payload``): ``normal`` (octahedral snorm16×2 of the face normal,
``ls_unpack_normal``), ``albedo`` (RGBA8 of the material), ``material`` (the material id). With a payload
the build rasterizes the full vertex buffer (normals and material ids); without, the indexed
position-only copy (``spec.indexed``).

**Invariants** (:meth:`LayeredStructure.invariants`, checked on every run; a violation makes the row
``degraded``): every fragment stored (no overflow unless the pool policy is ``fixed``; the adapters list
that overflow too, :func:`ldbench.methods.invariants.layered_invariants`), every stored fragment reachable exactly
once, every list sorted, no abandoned insert.

Also here: the orthographic layers of a bounding sphere (:func:`ortho_layers`, :func:`bind_ortho_layers`)
that the LDMs, the CDI and the LDIs use, and :func:`fill_uint`.
"""
from __future__ import annotations

import numpy as np

from ldbench.core.bindings import B
from ldbench.core.errors import LdbenchError
from ldbench.core.gpu import GLSL_DIR
from ldbench.methods.directions import orthonormal_basis

from .spec import StructureSpec

LAYOUT_CODES = {"linked": 1, "linear": 2}
B_COUNTERS, B_HEADS, B_LAYERS, B_NODES0, B_PAYLOAD, B_ALBEDO = (B.COUNTERS, B.HEADS, B.LAYERS, B.NODES0, B.PAYLOAD,
                                                                B.LS_ALBEDO)
N_COUNTERS = 16
C_CAPACITY = 8


class LayeredStructure:
    """Base of the layouts (see the module docstring). Subclasses implement the build and statistics.

    Parameters
    ----------
    gpu, geometry, res : :class:`~ldbench.core.gpu.Gpu`, :class:`~ldbench.methods.gbuffer.SceneGeometry` to rasterize,
        :class:`~ldbench.core.gpu.Resources` accounting for the buffers.
    spec : the :class:`~ldbench.methods.structures.spec.StructureSpec` (layout, source, assembly, pool, knobs).
    layers, width, height : number of layers and their size in texels.
    prefix : the buffers' names start with it.

    The fragment source is attached by :func:`ldbench.methods.structures.factory.make_structure`
    (:meth:`attach_source`); :meth:`fragment_pass` runs it.
    """

    layout = ""
    #: pool slots allocated now, and the most the GPU's limits allow (the layout's :meth:`allocate` sets them)
    capacity: int
    max_capacity: int
    #: slots to shrink the pool to before the next build (0: keep it)
    _shrink_to: int

    def __init__(self, gpu, geometry, res, spec: StructureSpec, *, layers: int, width: int,
                 height: int | None = None, prefix: str = "ls."):
        if spec.layout != self.layout:
            raise LdbenchError(f"structure.layout={spec.layout!r} given to the {self.layout!r} layout")
        self.gpu, self.geo, self.res, self.prefix, self.spec = gpu, geometry, res, prefix, spec
        self.layers, self.width = int(layers), int(width)
        self.height = int(height if height is not None else width)
        self.payload = spec.payload
        self.instanced, self.indexed = spec.instanced, spec.indexed
        self.n_lists = self.layers * self.width * self.height
        self.ssbo_limit = int(gpu.ctx.info.get("GL_MAX_SHADER_STORAGE_BLOCK_SIZE") or (1 << 27))
        per_texel = self.n_lists + (1 if self.layout == "linear" else 0)  # heads, or offsets + the total
        if per_texel * 4 > self.ssbo_limit:
            raise LdbenchError(
                f"{self.layers} layers of {self.width}x{self.height} texels need a {per_texel * 4 / 2**20:.1f} "
                f"MiB head/offset buffer, above this GPU's SSBO limit of {self.ssbo_limit / 2**20:.0f} MiB")
        gpu.check_gl_size(self.width, self.height)   # the raster's framebuffer
        self.overflow_allowed = spec.pool == "fixed"  # the adapters add the overflow back (ldbench/methods/invariants.py)
        self.counters_buf = res.buffer(prefix + "counters", reserve=4 * N_COUNTERS)
        self.layers_buf = res.buffer(prefix + "layers", reserve=80 * self.layers)
        self.fbo = gpu.ctx.empty_framebuffer((self.width, self.height))
        self.source = None
        self.have_layers = False
        self.layer_scale, self.layers_affine = 0.0, True
        self.layer_clip: np.ndarray | None = None

    def allocate(self, capacity: int):
        """(Re)allocate the pool for ``capacity`` fragments, clamped to :attr:`max_capacity` (each layout)."""
        raise NotImplementedError

    def resize_pool(self, need: int) -> None:
        """Before a build (the count and lazy pools): reallocate to ``need`` slots when they would not fit
        (up to the maximum) or when fewer than half of the present ones would be used."""
        if (need > self.capacity and self.capacity < self.max_capacity) or need < self.capacity // 2:
            self.allocate(max(need, 1))

    def refit_after_build(self, need: int, rebuild) -> None:
        """After a build that needed ``need`` slots (the grow pool, the first lazy build): grow and
        ``rebuild()`` when they did not fit, or shrink at the next build when fewer than half were used
        (the slots are in use this frame)."""
        if need > self.capacity and self.capacity < self.max_capacity:
            self.allocate(need)
            rebuild()
        elif need < self.capacity // 2:
            self._shrink_to = max(need, 1)

    @property
    def build_variant(self) -> str:
        return self.spec.source

    @property
    def assembly(self) -> str:
        return self.spec.assembly

    # ---- configuration ---------------------------------------------------------------------------
    def attach_source(self, source):
        """The fragment source every fragment pass of this structure runs (``source.run(extra, capacity)``)."""
        self.source = source
        return self

    def defines(self) -> dict:
        """``#define``s of every shader that includes ``layered/layered.glsl`` for this structure."""
        d = {"LS_LAYOUT": LAYOUT_CODES[self.layout], "LS_PAYLOAD": len(self.payload)}
        for i, name in enumerate(self.payload):
            d[f"LS_PL_{name.upper()}"] = i
        return d

    def set_layers(self, clip: np.ndarray, depth_rows: np.ndarray):
        """Per-layer world→clip matrices (L, 4, 4), column-vector convention, and depth rows (L, 4)."""
        clip = np.asarray(clip, np.float64).reshape(self.layers, 4, 4)
        rows = np.asarray(depth_rows, np.float64).reshape(self.layers, 4)
        data = np.empty((self.layers, 20), np.float32)
        data[:, :16] = clip.transpose(0, 2, 1).reshape(self.layers, 16)  # GLSL column-major
        data[:, 16:] = rows
        self.layers_buf.write(data.tobytes())
        self.have_layers = True
        self.layer_clip = clip
        self.layer_scale, self.layers_affine = layer_scale(clip, self.width, self.height)

    # ---- shared passes ---------------------------------------------------------------------------
    def fragment_pass(self, extra: dict, capacity: int):
        """One pass of the fragment source into every layer, storing through ``ls_store`` compiled with
        ``extra`` defines (``LS_PASS_COUNT``, ``LS_EMIT``, ``LL_SORTED``...)."""
        if not self.have_layers:
            raise LdbenchError(f"{type(self).__name__}.build: set_layers() was not called")
        if self.source is None:
            raise LdbenchError(f"{type(self).__name__}: no fragment source attached (use make_structure)")
        self.source.run(extra, capacity)

    def read_counters(self) -> np.ndarray:
        return np.frombuffer(self.gpu.read(self.counters_buf), np.uint32).copy()

    def stats_pass(self, shader: str, first: int, last: int) -> np.ndarray:
        """Zero counters ``first … last``, run the statistics ``shader`` over every list, read them back."""
        c = self.read_counters()
        c[first:last + 1] = 0
        self.counters_buf.write(c.tobytes())
        cs = self.gpu.compute(GLSL_DIR / shader, self.defines())
        cs["n_lists"].value = self.n_lists
        self.bind()
        cs.run(min(-(-self.n_lists // 64), 8192))
        self.gpu.ctx.memory_barrier()
        return self.read_counters()

    def reset_counters(self, capacity: int):
        c = np.zeros(N_COUNTERS, np.uint32)
        c[C_CAPACITY] = min(int(capacity), 0xFFFFFFFF)
        self.counters_buf.write(c.tobytes())

    def build_stats(self) -> dict:
        """The build's part of :meth:`stats`: variant, assembly and the source's own counters."""
        out = {"build_variant": self.build_variant, "assembly": self.assembly}
        if self.source is not None:
            out.update(self.source.stats())
        return out

    # ---- the interface subclasses implement ------------------------------------------------------
    def build(self, stage=None):
        raise NotImplementedError

    def bind(self):
        raise NotImplementedError

    def stats(self) -> dict:
        raise NotImplementedError

    def lists(self, payload: bool = False) -> list:
        """Every list in storage order: ``out[layer][y][x]`` = depths (OpenGL rows, y = 0 at the
        bottom); with ``payload``, (depth, (words...)) pairs. For tests and debugging."""
        raise NotImplementedError

    def free_scratch(self):
        """Release what only a build needs (the peel's scratch); the structure itself stays valid."""
        if self.source is not None:
            self.source.free_scratch()

    def invariants(self, stats: dict) -> list[str]:
        """Violated invariants of the last build (one line each); empty when the structure is complete."""
        out = []
        if stats.get("overflow", 0) and not self.overflow_allowed:
            out.append(f"{stats['overflow']} of {stats['fragments']} fragments not stored (pool overflow)")
        if stats.get("linked_nodes", stats.get("fragments_stored")) != stats.get("fragments_stored"):
            out.append(f"{stats['linked_nodes']} nodes reachable != {stats['fragments_stored']} stored")
        if stats.get("unsorted_lists", 0):
            out.append(f"{stats['unsorted_lists']} lists out of depth order")
        if stats.get("insert_failures", 0):
            out.append(f"{stats['insert_failures']} inserts abandoned")
        if self.source is not None:
            out += self.source.invariants(stats)
        return out

    def memory(self) -> dict:
        """{buffer name: bytes} of this structure's buffers."""
        return {self.res.prefix + k: v for k, v in self.res.bytes.items() if k.startswith(self.prefix)}


def layer_scale(clip: np.ndarray, width: int, height: int) -> tuple[float, bool]:
    """(the most texels per world unit of any layer, whether every layer is affine (w = 1))."""
    clip = np.asarray(clip, np.float64)
    s = np.maximum(np.linalg.norm(clip[:, 0, :3], axis=1) * width / 2,
                   np.linalg.norm(clip[:, 1, :3], axis=1) * height / 2)
    affine = bool(np.all(clip[:, 3, :3] == 0) and np.all(clip[:, 3, 3] == 1))
    return float(s.max()), affine


def bounding_sphere(scene) -> tuple[np.ndarray, float]:
    """(centre, radius) of a scene: the bounds' centre and the distance to the farthest vertex (float64)."""
    v, _, _, _ = scene.merged()
    lo, hi = scene.bounds()
    c = 0.5 * (lo + hi)
    r = float(np.sqrt(((v.astype(np.float64) - c) ** 2).sum(1).max()))
    return c, max(r, 1e-6)


def ortho_layers(axes: np.ndarray, centre: np.ndarray, radius: float):
    """Orthographic layers looking along ``axes`` (N, 3) at the sphere (``centre``, ``radius``): per layer the
    clip matrix (N, 4, 4; the sphere fills the layer, depth inside the clip volume with a 1 % margin), the
    depth row (N, 4: distance along the axis from the plane through the centre) and the (u, w, axis)
    basis. The LDMs of aalund2015, the CDI of archer2019 and the LDIs use them."""
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


B_ORTHO_AXES = B.ORTHO_AXES  # ldbench/methods/glsl/layered/ortho_layers.glsl


def bind_ortho_layers(cs, axes_buf, centre, radius: float, resolution: int) -> None:
    """The uniforms and the axes buffer (the (u, w, v) basis of :func:`ortho_layers`, as vec4 rows) of a
    program that includes ``layered/ortho_layers.glsl``; a uniform the program does not use is skipped."""
    for name, v in (("ol_centre", tuple(float(x) for x in centre)), ("ol_radius", float(radius)),
                    ("ol_size", (int(resolution), int(resolution)))):
        if name in cs:
            cs[name].value = v
    axes_buf.bind_to_storage_buffer(B_ORTHO_AXES)


def fill_uint(gpu, buffer, n: int, value: int):
    """``buffer[0 .. n) = value`` on the GPU (``ldbench/methods/glsl/common/fill_uint.glsl``)."""
    cs = gpu.compute(GLSL_DIR / "common/fill_uint.glsl")
    cs["n"].value = int(n)
    cs["value"].value = int(value)
    buffer.bind_to_storage_buffer(B.FILL)
    cs.run(max(1, min(-(-int(n) // 256), 4096)))
    gpu.ctx.memory_barrier()
