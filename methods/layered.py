"""Layered depth structures: one Python API and one GLSL access interface for every layout.

The seed methods are ray tracers over rasterized layered depth structures: ``layers`` images of
``width × height`` texels, each texel holding the depths (and payload words) of *every* surface its
centre sees along the layer's projection. This module is their common base; the layouts are

============  ================================================================  =========================
layout        memory                                                            module
============  ================================================================  =========================
``linked``    per-texel linked lists: head image + node pool + atomic counter;  :mod:`methods.linked_list`
              lock-free sorted insert (aalund2015) or yang2010 insert + sort
``linear``    linearised arrays: count → GPU prefix sum → fill → per-list sort  :mod:`methods.linear_arrays`
              (archer2019); a texel's fragments are contiguous
============  ================================================================  =========================

Compacted depth-peeled layers (niessner2010) have the ``linear`` memory layout (a prefix sum over
per-texel layer counts) and are read through the same interface.

**GLSL** (``methods/glsl/layered.glsl``, compiled with :meth:`LayeredStructure.defines`):
``ls_list(layer, px, size)``, ``ls_first(list)``, ``ls_next(list, node)``, ``ls_depth(node)``,
``ls_payload(node, k)``, ``ls_bound()``, ``ls_count(list)``. A tracer written against it reads every layout.

**Payload** words per node, chosen per structure (``payload=("normal", "albedo")``): ``normal``
(octahedral snorm16×2 of the face normal, ``ls_unpack_normal``), ``albedo`` (RGBA8 of the material),
``material`` (the material id). With a payload the build rasterizes the full vertex buffer (normals and
material ids); without, the indexed position-only copy.

**Builds** (:meth:`LayeredStructure.set_build`, or ``make_structure(..., build=...)``), every layout:

* ``raster`` (default): the scene rasterized in each layer's own view, one instanced draw
  (``gl_InstanceID`` = layer; ``instanced=False``: one draw per layer, the "brute force" of archer2019),
  both faces, no depth test (``methods/glsl/layered_build.glsl``). Texel centres are sampled exactly.
* ``one_pass`` (archer2019 §3.1): the scene rasterized *once*, each triangle swizzled to its dominant
  axis over the square of a bounding sphere (``sphere`` = (centre, radius), default the geometry's;
  ``raster_size``² samples, default the layer size), and every fragment projected into each layer in the
  fragment shader (``methods/glsl/layered_build_one_pass.glsl``); ``pass_layers`` > 0 splits the layers
  into passes of that many (1 = one raster per layer of the *same* fragments: identical lists up to
  order). Not conservative: a layer sees a triangle's fragments at the raster's sample positions, not at
  its own texel centres (holes where a triangle is more face-on to the layer than to its dominant axis,
  extra fragments where it is edge-on).
* ``splat``: a compute-shader rasterizer of the small triangles with the hardware's fill rule (the same
  fragments as ``raster``), the triangles longer than ``splat_max`` texels drawn by the hardware in the
  same pass (:class:`methods.layered_builds.Splat`; affine layers only).

``assembly`` (linear layout): ``direct`` (count → scan → fill → sort: two fragment passes) or ``sort``
(one pass appends (list, depth) pairs, then scan → scatter by list → sort: :func:`methods.layered_builds
.build_sorted`). Every fragment pass of every layout and assembly runs the chosen ``build``.

Each layer ``k`` has a clip transform ``clip[k]`` (world → clip) and a depth row ``depth_row[k]``; the
stored depth is ``dot(depth_row, (p, 1))`` of the fragment's world position (interpolated
perspective-correctly, so any depth linear in world space is exact).

**Invariants** (:meth:`LayeredStructure.invariants`, checked on every run; a violation makes the row
``degraded``): every fragment stored (no overflow unless the pool policy is ``fixed``), every stored
fragment reachable exactly once, every list sorted, no abandoned insert.
"""
from __future__ import annotations

import numpy as np

from harness.bindings import B
from harness.errors import LdbenchError
from harness.gpu import GLSL_DIR
from .directions import orthonormal_basis

PAYLOAD_WORDS = ("normal", "albedo", "material")
LAYOUT_CODES = {"linked": 1, "linear": 2}
BUILDS = ("raster", "one_pass", "splat")
ASSEMBLIES = ("direct", "sort")
B_COUNTERS, B_HEADS, B_LAYERS, B_NODES0, B_PAYLOAD, B_ALBEDO = (B.COUNTERS, B.HEADS, B.LAYERS, B.NODES0, B.PAYLOAD,
                                                                B.LS_ALBEDO)
N_COUNTERS = 16
C_CAPACITY = 8


class LayeredStructure:
    """Base of the layouts (see the module docstring). Subclasses implement the build and statistics.

    Parameters
    ----------
    gpu, geometry, res : :class:`~harness.gpu.Gpu`, :class:`~methods.gbuffer.SceneGeometry` to rasterize,
        :class:`~harness.gpu.Resources` accounting for the buffers.
    layers, width, height : number of layers and their size in texels.
    payload : names from :data:`PAYLOAD_WORDS`, one 32-bit word each, in this order.
    instanced : one instanced draw for all layers (True) or one draw per layer.
    indexed : without payload, rasterize the indexed position-only geometry (same fragments).
    """

    layout = ""

    def __init__(self, gpu, geometry, res, *, layers: int, width: int, height: int | None = None,
                 payload: tuple = (), instanced: bool = True, indexed: bool = True, prefix: str = "ls."):
        self.gpu, self.geo, self.res, self.prefix = gpu, geometry, res, prefix
        self.layers, self.width = int(layers), int(width)
        self.height = int(height if height is not None else width)
        payload = tuple(payload)
        bad = [p for p in payload if p not in PAYLOAD_WORDS]
        if bad or len(set(payload)) != len(payload):
            raise LdbenchError(f"payload {payload!r}: words must be distinct names from {list(PAYLOAD_WORDS)}")
        self.payload = payload
        self.instanced, self.indexed = bool(instanced), bool(indexed)
        self.n_lists = self.layers * self.width * self.height
        self.ssbo_limit = int(gpu.ctx.info.get("GL_MAX_SHADER_STORAGE_BLOCK_SIZE") or (1 << 27))
        per_texel = self.n_lists + (1 if self.layout == "linear" else 0)  # heads, or offsets + the total
        if per_texel * 4 > self.ssbo_limit:
            raise LdbenchError(
                f"{self.layers} layers of {self.width}x{self.height} texels need a {per_texel * 4 / 2**20:.1f} "
                f"MiB head/offset buffer, above this GPU's SSBO limit of {self.ssbo_limit / 2**20:.0f} MiB")
        self.counters_buf = res.buffer(prefix + "counters", reserve=4 * N_COUNTERS)
        self.layers_buf = res.buffer(prefix + "layers", reserve=80 * self.layers)
        self.fbo = gpu.ctx.empty_framebuffer((self.width, self.height))
        self._vaos: dict = {}
        self._have_layers = False
        self.build_variant, self.pass_layers, self.sphere, self.raster_size = "raster", 0, None, 0
        self.assembly, self.splat = "direct", None
        self.layer_scale, self.layers_affine = 0.0, True

    # ---- configuration ---------------------------------------------------------------------------
    def defines(self) -> dict:
        """``#define``s of every shader that includes ``layered.glsl`` for this structure."""
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
        self._have_layers = True
        from methods.layered_builds import layer_scale

        self.layer_scale, self.layers_affine = layer_scale(clip, self.width, self.height)

    def set_build(self, build: str = "raster", *, pass_layers: int = 0, sphere=None, raster_size: int = 0,
                  assembly: str = "direct", splat_max: float = 16.0, splat_batch: int = 8):
        """Choose the build variant (module docstring): ``raster``, ``one_pass`` (with ``pass_layers``
        layers per pass, 0 = all; ``sphere`` = (centre, radius) the swizzled raster covers, default the
        geometry's bounding sphere; ``raster_size`` samples per side, 0 = the larger layer side) or
        ``splat`` (``splat_max`` texels: longest edge splatted, longer ones rasterized; ``splat_batch``
        layers per invocation); ``assembly`` ``direct`` or ``sort`` (linear layout)."""
        if build not in BUILDS:
            raise LdbenchError(f"layered build {build!r} not one of {list(BUILDS)}")
        if assembly not in ASSEMBLIES:
            raise LdbenchError(f"layered assembly {assembly!r} not one of {list(ASSEMBLIES)}")
        if assembly == "sort" and self.layout != "linear":
            raise LdbenchError("assembly 'sort' needs the linear layout")
        if int(pass_layers) < 0 or int(raster_size) < 0:
            raise LdbenchError("pass_layers and raster_size must be >= 0")
        if build == "splat":
            from methods.layered_builds import Splat

            self.splat = Splat(self, splat_max, splat_batch)
        if assembly != self.assembly:
            self.assembly = assembly
            self._allocate(self.capacity)  # the sort assembly's pairs
        self.build_variant, self.pass_layers = build, int(pass_layers)
        self.raster_size = int(raster_size)
        if build == "one_pass":
            c, r = bounding_sphere(self.geo.scene) if sphere is None else sphere
            self.sphere = (np.asarray(c, np.float64).reshape(3), float(r))
            side = self.raster_size or max(self.width, self.height)
            self.one_pass_fbo = self.gpu.ctx.empty_framebuffer((side, side))
            self.one_pass_side = side
        return self

    # ---- shared passes ---------------------------------------------------------------------------
    def _raster_program(self, extra: dict):
        d = {**self.defines(), **extra}
        shader = "layered_build_one_pass.glsl" if self.build_variant == "one_pass" else "layered_build.glsl"
        prog = self.gpu.program(GLSL_DIR / shader, d)
        key = id(prog)
        if key not in self._vaos:
            self._vaos[key] = (self.geo.vao(prog) if self.payload or not self.indexed
                               else self.geo.vao_positions(prog))
        return prog, self._vaos[key]

    def _raster(self, extra: dict, capacity: int):
        """One geometry pass into every layer with the build shader compiled with ``extra`` defines."""
        if not self._have_layers:
            raise LdbenchError(f"{type(self).__name__}.build: set_layers() was not called")
        if self.build_variant == "splat":
            return self.splat.run(extra, capacity)
        ctx = self.gpu.ctx
        prog, vao = self._raster_program(extra)
        if "ls_size" in prog:
            prog["ls_size"].value = (self.width, self.height)
        if "ls_capacity" in prog:
            prog["ls_capacity"].value = int(capacity)
        self.bind()
        if "albedo" in self.payload:
            self.geo.albedo.bind_to_storage_buffer(B_ALBEDO)
        ctx.disable(ctx.DEPTH_TEST | ctx.CULL_FACE | ctx.BLEND)
        if self.build_variant == "one_pass":
            c, r = self.sphere
            prog["op_centre"].value = tuple(float(x) for x in c)
            prog["op_radius"].value = r
            self.one_pass_fbo.use()
            self.one_pass_fbo.viewport = (0, 0, self.one_pass_side, self.one_pass_side)
            step = self.pass_layers or self.layers
            for k in range(0, self.layers, step):
                prog["layer_base"].value = k
                prog["layer_count"].value = min(step, self.layers - k)
                vao.render()
            ctx.memory_barrier()
            return
        self.fbo.use()
        self.fbo.viewport = (0, 0, self.width, self.height)
        if self.instanced:
            if "layer_base" in prog:
                prog["layer_base"].value = 0
            vao.render(instances=self.layers)
        else:
            for k in range(self.layers):
                prog["layer_base"].value = k
                vao.render()
        ctx.memory_barrier()

    def _counters(self) -> np.ndarray:
        return np.frombuffer(self.gpu.read(self.counters_buf), np.uint32).copy()

    def _stats_pass(self, shader: str, first: int, last: int) -> np.ndarray:
        """Zero counters ``first … last``, run the statistics ``shader`` over every list, read them back."""
        c = self._counters()
        c[first:last + 1] = 0
        self.counters_buf.write(c.tobytes())
        cs = self.gpu.compute(GLSL_DIR / shader, self.defines())
        cs["n_lists"].value = self.n_lists
        self.bind()
        cs.run(min(-(-self.n_lists // 64), 8192))
        self.gpu.ctx.memory_barrier()
        return self._counters()

    def _reset_counters(self, capacity: int):
        c = np.zeros(N_COUNTERS, np.uint32)
        c[C_CAPACITY] = min(int(capacity), 0xFFFFFFFF)
        self.counters_buf.write(c.tobytes())

    def build_stats(self) -> dict:
        """The build's part of :meth:`stats`: variant, assembly, triangles the splat left to the hardware."""
        out = {"build_variant": self.build_variant, "assembly": self.assembly}
        if self.splat is not None and self.build_variant == "splat":
            out["splat_large_triangles"] = self.splat.large_triangles()
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

    def invariants(self, stats: dict) -> list[str]:
        """Violated invariants of the last build (one line each); empty when the structure is complete."""
        out = []
        if stats.get("overflow", 0) and not getattr(self, "overflow_allowed", False):
            out.append(f"{stats['overflow']} of {stats['fragments']} fragments not stored (pool overflow)")
        if stats.get("linked_nodes", stats.get("fragments_stored")) != stats.get("fragments_stored"):
            out.append(f"{stats['linked_nodes']} nodes reachable != {stats['fragments_stored']} stored")
        if stats.get("unsorted_lists", 0):
            out.append(f"{stats['unsorted_lists']} lists out of depth order")
        if stats.get("insert_failures", 0):
            out.append(f"{stats['insert_failures']} inserts abandoned")
        return out

    def memory(self) -> dict:
        """{buffer name: bytes} of this structure's buffers."""
        return {self.res.prefix + k: v for k, v in self.res.bytes.items() if k.startswith(self.prefix)}


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


B_ORTHO_AXES = B.ORTHO_AXES  # methods/glsl/ortho_layers.glsl


def bind_ortho_layers(cs, axes_buf, centre, radius: float, resolution: int) -> None:
    """The uniforms and the axes buffer (the (u, w, v) basis of :func:`ortho_layers`, as vec4 rows) of a
    program that includes ``ortho_layers.glsl``; a uniform the program does not use is skipped."""
    for name, v in (("ol_centre", tuple(float(x) for x in centre)), ("ol_radius", float(radius)),
                    ("ol_size", (int(resolution), int(resolution)))):
        if name in cs:
            cs[name].value = v
    axes_buf.bind_to_storage_buffer(B_ORTHO_AXES)


def fill_uint(gpu, buffer, n: int, value: int):
    """``buffer[0 .. n) = value`` on the GPU (``methods/glsl/fill_uint.glsl``)."""
    cs = gpu.compute(GLSL_DIR / "fill_uint.glsl")
    cs["n"].value = int(n)
    cs["value"].value = int(value)
    buffer.bind_to_storage_buffer(B.FILL)
    cs.run(max(1, min(-(-int(n) // 256), 4096)))
    gpu.ctx.memory_barrier()


def make_structure(layout: str, gpu, geometry, res, *, build: str = "raster", pass_layers: int = 0,
                   sphere=None, raster_size: int = 0, assembly: str = "direct", splat_max: float = 16.0,
                   splat_batch: int = 8, **kw) -> LayeredStructure:
    """A structure of ``layout`` (``linked`` | ``linear``); ``kw`` are the layout's parameters; ``build``
    (``raster`` | ``one_pass`` | ``splat``), ``assembly`` and their options as :meth:`LayeredStructure.set_build`."""
    from methods.linear_arrays import LinearisedArrays
    from methods.linked_list import LayeredLinkedLists

    classes = {"linked": LayeredLinkedLists, "linear": LinearisedArrays}
    if layout not in classes:
        raise LdbenchError(f"unknown layered layout {layout!r} (known: {', '.join(classes)})")
    s = classes[layout](gpu, geometry, res, **kw)
    return s.set_build(build, pass_layers=pass_layers, sphere=sphere, raster_size=raster_size,
                       assembly=assembly, splat_max=splat_max, splat_batch=splat_batch)
