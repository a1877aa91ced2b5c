"""Compacted depth-peeled layers (niessner2010 §3.1) in the ``linear`` layout of :mod:`methods.layered`.

Two builds give the same structure, bit for bit (``tests/test_ldi.py``):

``peel`` (:class:`PeeledLayers`), the paper's build, stages:

``peel``     per layer m: two raster passes of every LDI at once (``peel.glsl``: the smallest depth above
             layer m − 1's key, then the smallest triangle id at that depth: coincident fragments are
             peeled one per layer, not lost) and a commit pass (``peel_commit.glsl``) that appends the
             texel's layer m (texel, m, depth, triangle) to a scratch list and counts the layer's
             fragments in an atomic counter. Peeling stops after the first pass that finds no fragment
             (one 4-byte read-back per layer, as the paper's occlusion query) or at ``max_layers``.
``scan``     the per-texel layer counts m_i, GPU exclusive prefix sum (:class:`methods.scan.Scan`,
             the paper's CPU compaction done on the GPU); the total sizes the arrays.
``scatter``  scratch entry → slot begin(texel) + m: depth and payload (normal and albedo looked up from the
             triangle id, the paper's "triangle ids", packed as the one-pass build packs them).
``canon``    :func:`canonicalize`: ties at equal depth ordered by their payload words.

``single_pass`` (:func:`single_pass_structure`): the shared one-pass linearised arrays
(``make_structure("linear")``: count → scan → fill → sort) followed by the same ``canon`` stage.

Layout: the ``linear`` layout's buffers (offsets holding each list's end, depth array, payload words), read
by tracers through ``methods/glsl/layered.glsl`` (``LS_LAYOUT = 2``). Scratch of the peel: per texel the
last key, the candidate key and the layer count (20 bytes), and 16 bytes per fragment; it is kept between
frames and freed by :meth:`PeeledLayers.free_scratch` (``prebuild``).

Invariants (besides the ``linear`` layout's): peeling ended because a pass found nothing (not at
``max_layers``), no scratch overflow, the scratch holds as many fragments as the offsets count.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from harness.bindings import B
from harness.errors import LdbenchError
from methods.layered import B_ALBEDO, C_CAPACITY, fill_uint, make_structure
from methods.linear_arrays import C_COUNTED, C_FILLED, C_OVERFLOW, LinearisedArrays

HERE = Path(__file__).parent
B_PREV, B_CAND, B_COUNT, B_LOC, B_FRAG, B_PCOUNT, B_VERTS = (B.PEEL_PREV, B.PEEL_CAND, B.PEEL_COUNT, B.PEEL_LOC,
                                                              B.PEEL_FRAG, B.PEEL_COUNTERS, B.PEEL_VERTICES)
NONE = 0xFFFFFFFF
PAYLOAD = ("normal", "albedo")


def _groups(n: int, per: int = 256) -> int:
    return max(1, min(-(-int(n) // per), 65535))


def canonicalize(structure, stage):
    """Stage ``canon``: order fragments at equal depth by payload (``canon.glsl``)."""
    gpu = structure.gpu
    with stage("canon"):
        cs = gpu.compute(HERE / "canon.glsl", structure.defines())
        cs["n_lists"].value = structure.n_lists
        structure.bind()
        cs.run(min(-(-structure.n_lists // 64), 8192))
        gpu.ctx.memory_barrier()


class PeeledLayers(LinearisedArrays):
    """``layers`` LDIs of ``width × height`` texels built by depth peeling (module docstring).

    ``max_layers`` bounds the peel (a pathological scene cannot loop for ever); reaching it with fragments
    left is an invariant violation, never silent.
    """

    layout = "linear"
    build_kind = "peel"

    def __init__(self, gpu, geometry, res, *, layers: int, width: int, height: int | None = None,
                 payload: tuple = PAYLOAD, max_layers: int = 1024, instanced: bool = True, prefix: str = "ldi."):
        super().__init__(gpu, geometry, res, layers=layers, width=width, height=height, pool="grow",
                         payload=payload, instanced=instanced, indexed=False, prefix=prefix)
        self.max_layers = int(max_layers)
        if 8 * self.n_lists > self.ssbo_limit:
            raise LdbenchError(f"depth peeling {self.layers} LDIs of {self.width}x{self.height} pixels needs "
                               f"{8 * self.n_lists / 2**20:.0f} MiB per-pixel key arrays, above this GPU's SSBO limit "
                               f"of {self.ssbo_limit / 2**20:.0f} MiB")
        self.max_scratch = self.ssbo_limit // 8
        self.peel_layers = 0
        self.truncated = False
        self.scratch_capacity = 0
        self._scratch = None
        self._commit = gpu.compute(HERE / "peel_commit.glsl")
        self._ends = gpu.compute(HERE / "compact.glsl", {**self.defines(), "COMPACT_ENDS": 1})
        self._scatter = gpu.compute(HERE / "compact.glsl", {**self.defines(), "COMPACT_SCATTER": 1})

    # ---- scratch ----------------------------------------------------------------------------------
    def _state(self):
        if self._scratch is None:
            n, r, p = self.n_lists, self.res, self.prefix + "peel."
            self._scratch = {"prev": r.buffer(p + "prev", reserve=8 * n), "cand": r.buffer(p + "cand", reserve=8 * n),
                             "count": r.buffer(p + "count", reserve=4 * n),
                             "counters": r.buffer(p + "counters", reserve=16)}
            self._grow(n)
        return self._scratch

    def _grow(self, needed: int):
        """Scratch list of at least ``needed`` entries, its contents kept (grown by 1.5× at least)."""
        if needed <= self.scratch_capacity or self.scratch_capacity >= self.max_scratch:
            return
        cap = min(max(int(needed), self.scratch_capacity * 3 // 2, 1024), self.max_scratch)  # beyond: overflow
        r, p, s = self.res, self.prefix + "peel.", self._scratch
        old = (s.get("loc"), s.get("frag"))
        loc, frag = self.gpu.ctx.buffer(reserve=8 * cap), self.gpu.ctx.buffer(reserve=8 * cap)
        if old[0] is not None and self.scratch_capacity:
            self.gpu.ctx.copy_buffer(loc, old[0], 8 * self.scratch_capacity)
            self.gpu.ctx.copy_buffer(frag, old[1], 8 * self.scratch_capacity)
        for name, buf in (("loc", loc), ("frag", frag)):
            r._add(p + name, buf, buf.size)  # replaces (and releases) the old buffer
            s[name] = buf
        self.scratch_capacity = cap

    def free_scratch(self):
        """Release the peel's scratch buffers (the structure itself stays valid)."""
        if self._scratch is not None:
            for name in self._scratch:
                self.res.free(self.prefix + "peel." + name)
        self._scratch, self.scratch_capacity = None, 0

    # ---- build --------------------------------------------------------------------------------------
    def build(self, stage=None):
        """Stages ``peel``, ``scan``, ``scatter``, ``canon`` (``stage(name)`` times each)."""
        stage = stage or self.gpu.stage
        gpu, ctx, n = self.gpu, self.gpu.ctx, self.n_lists
        s = self._state()
        with stage("peel"):
            fill_uint(gpu, s["prev"], 2 * n, 0)
            fill_uint(gpu, s["cand"], 2 * n, NONE)
            fill_uint(gpu, s["count"], n, 0)
            s["counters"].write(np.zeros(4, np.uint32).tobytes())
            total, layer_frags, m = 0, n, 0
            self.truncated = False
            while True:
                self._grow(total + layer_frags)  # layer m has at most as many fragments as layer m - 1
                for p in (1, 2):
                    self._raster({"PEEL_PASS": p}, 0, program=HERE / "peel.glsl")
                self._commit["n_lists"].value = n
                self._commit["capacity"].value = self.scratch_capacity
                for name, b in (("prev", B_PREV), ("cand", B_CAND), ("count", B_COUNT), ("loc", B_LOC),
                                ("frag", B_FRAG), ("counters", B_PCOUNT)):
                    s[name].bind_to_storage_buffer(b)
                self._commit.run(_groups(n))
                ctx.memory_barrier()
                c = np.frombuffer(self.gpu.read(s["counters"]), np.uint32).copy()
                layer_frags, total = int(c[0]), int(c[1])
                self._scratch_overflow = int(c[2])
                if layer_frags == 0:
                    break
                m += 1
                if m >= self.max_layers:
                    self.truncated = True
                    break
                c[0] = 0
                s["counters"].write(c.tobytes())
            self.peel_layers = m
        with stage("scan"):
            ctx.copy_buffer(self.offsets, s["count"], 4 * n)
            self.offsets.write(np.zeros(1, np.uint32).tobytes(), offset=4 * n)
            self.scan.run(self.offsets, n + 1)
            self.total = int(np.frombuffer(self.gpu.read(self.offsets, 4, offset=4 * n), np.uint32)[0])
            if self.total > self.capacity or self.total < self.capacity // 2:
                self._allocate(max(self.total, 1))
            self._write_counters()
            self.bind()
            s["count"].bind_to_storage_buffer(B_COUNT)
            self._ends["n"].value = n
            self._ends.run(_groups(n))
            ctx.memory_barrier()
        with stage("scatter"):
            self.bind()
            for name, b in (("loc", B_LOC), ("frag", B_FRAG)):
                s[name].bind_to_storage_buffer(b)
            self.geo.vbo.bind_to_storage_buffer(B_VERTS)
            self.geo.albedo.bind_to_storage_buffer(B_ALBEDO)
            self._scatter["n"].value = min(total, self.scratch_capacity)
            self._scatter.run(_groups(total))
            ctx.memory_barrier()
        self._scratch_total = total
        canonicalize(self, stage)

    def _write_counters(self):
        """The ``linear`` layout's counters; fragments beyond the arrays (the SSBO limit) are overflow."""
        c = np.zeros(16, np.uint32)
        c[C_CAPACITY] = self.capacity
        c[C_COUNTED] = c[C_FILLED] = min(self.total, 0xFFFFFFFF)
        c[C_OVERFLOW] = max(0, self.total - self.capacity)
        self.counters_buf.write(c.tobytes())

    def _raster(self, extra: dict, capacity: int, program=None):
        """One raster pass of every LDI with ``program`` (default: the shared build shader)."""
        if program is None:
            return super()._raster(extra, capacity)
        ctx = self.gpu.ctx
        prog = self.gpu.program(program, {**self.defines(), **extra})
        key = id(prog)
        if key not in self._vaos:
            self._vaos[key] = self.geo.vao(prog)
        prog["ls_size"].value = (self.width, self.height)
        self.layers_buf.bind_to_storage_buffer(B.LAYERS)
        self._scratch["prev"].bind_to_storage_buffer(B_PREV)
        self._scratch["cand"].bind_to_storage_buffer(B_CAND)
        self.fbo.use()
        self.fbo.viewport = (0, 0, self.width, self.height)
        ctx.disable(ctx.DEPTH_TEST | ctx.CULL_FACE | ctx.BLEND)
        self._vaos[key].render(instances=self.layers)
        ctx.memory_barrier()

    # ---- statistics ---------------------------------------------------------------------------------
    def stats(self) -> dict:
        c = super().stats()
        c.update(build="peel", peel_layers=self.peel_layers, peel_raster_passes=2 * (self.peel_layers + 1),
                 peel_truncated=self.truncated, peel_scratch_fragments=getattr(self, "_scratch_total", 0),
                 peel_scratch_overflow=getattr(self, "_scratch_overflow", 0))
        return c

    def invariants(self, stats: dict) -> list[str]:
        out = super().invariants(stats)
        if stats.get("peel_truncated"):
            out.append(f"depth peeling stopped at max_layers = {self.max_layers} with fragments left")
        if stats.get("peel_scratch_overflow"):
            out.append(f"{stats['peel_scratch_overflow']} peeled fragments beyond the scratch list")
        if stats.get("peel_scratch_fragments") != stats.get("fragments"):
            out.append(f"{stats.get('peel_scratch_fragments')} peeled fragments != {stats.get('fragments')} "
                       f"counted by the offsets")
        return out


class SinglePassLayers:
    """``build = single_pass``: the shared one-pass linearised arrays plus the ``canon`` stage, so that the
    result is the peel's structure bit for bit. Everything else is the wrapped structure's. ``raster``:
    ``hardware`` or ``splat`` (the compute splat), ``assembly``: ``direct`` or ``sort`` — the shared
    structure's fast builds (docs/fast_builds.md)."""

    build_kind = "single_pass"

    def __init__(self, gpu, geometry, res, *, layers: int, width: int, height: int | None = None,
                 payload: tuple = PAYLOAD, max_list: int = 64, instanced: bool = True, prefix: str = "ldi.",
                 raster: str = "hardware", assembly: str = "direct"):
        self._s = make_structure("linear", gpu, geometry, res, layers=layers, width=width, height=height,
                                 payload=payload, max_list=max_list, instanced=instanced, indexed=False,
                                 prefix=prefix, build="splat" if raster == "splat" else "raster",
                                 assembly=assembly)

    def __getattr__(self, name):
        return getattr(self._s, name)

    def build(self, stage=None):
        stage = stage or self._s.gpu.stage
        self._s.build(stage)
        canonicalize(self._s, stage)

    def stats(self) -> dict:
        c = self._s.stats()
        c["build"] = "single_pass"  # the structure's own build variant stays in c["build_variant"]
        return c

    def invariants(self, stats: dict) -> list[str]:
        return self._s.invariants(stats)

    def free_scratch(self):
        pass


def make_ldi_structure(build: str, gpu, geometry, res, **kw):
    """The LDI structure of ``build`` (``peel`` | ``single_pass``); each drops the options of the other
    (``LdiParams`` refuses a peel with a fast-build option)."""
    if build == "peel":
        for k in ("max_list", "raster", "assembly"):
            kw.pop(k, None)
        return PeeledLayers(gpu, geometry, res, **kw)
    kw.pop("max_layers", None)
    return SinglePassLayers(gpu, geometry, res, **kw)
