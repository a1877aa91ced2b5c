"""The ``peel`` source: compacted depth-peeled layers (niessner2010 §3.1) in the ``linear`` layout.

:class:`Peel` assembles the linear arrays itself (``assembles``), stages:

``peel``     per layer m: two raster passes of every layer at once (``layered/peel.glsl``: the smallest
             depth above layer m − 1's key, then the smallest triangle id at that depth: coincident
             fragments are peeled one per layer, not lost) and a commit pass (``layered/peel_commit.glsl``)
             that appends the texel's layer m (texel, m, depth, triangle) to a scratch list and counts the
             layer's fragments in an atomic counter. Peeling stops after the first pass that finds no
             fragment (one 4-byte read-back per layer, as the paper's occlusion query) or at ``max_layers``.
``scan``     the per-texel layer counts m_i, GPU exclusive prefix sum (:class:`ldbench.methods.scan.Scan`,
             the paper's CPU compaction done on the GPU); the total sizes the arrays.
``scatter``  scratch entry → slot begin(texel) + m: depth and payload (normal, albedo, material looked up from the
             triangle id, the paper's "triangle ids", packed as the raster packs them;
             ``layered/compact.glsl``).

With ``spec.canonical`` the layout's ``canon`` stage follows; the structure is then the one the ``raster``
source gives, bit for bit (``tests/test_ldi.py``).

Scratch: per texel the last key, the candidate key and the layer count (20 bytes), and 16 bytes per
fragment; it is kept between frames and freed by :meth:`Peel.free_scratch`.

Invariants (besides the ``linear`` layout's): peeling ended because a pass found nothing (not at
``max_layers``), no scratch overflow, the scratch holds as many fragments as the offsets count.
"""
from __future__ import annotations

import numpy as np

from ldbench.core.bindings import B
from ldbench.core.errors import LdbenchError
from ldbench.core.gpu import GLSL_DIR

from .core import B_ALBEDO, B_LAYERS, C_CAPACITY, fill_uint
from .linear import C_COUNTED, C_FILLED, C_OVERFLOW
from .sources import FragmentSource

B_PREV, B_CAND, B_COUNT, B_LOC, B_FRAG, B_PCOUNT, B_VERTS = (B.PEEL_PREV, B.PEEL_CAND, B.PEEL_COUNT, B.PEEL_LOC,
                                                              B.PEEL_FRAG, B.PEEL_COUNTERS, B.PEEL_VERTICES)
NONE = 0xFFFFFFFF


def _groups(n: int, per: int = 256) -> int:
    return max(1, min(-(-int(n) // per), 65535))


class Peel(FragmentSource):
    """Depth peeling of every layer of a ``linear`` structure (module docstring).

    ``spec.max_layers`` bounds the peel (a pathological scene cannot loop for ever); reaching it with
    fragments left is an invariant violation, never silent.
    """

    assembles = True

    def __init__(self, structure):
        super().__init__(structure)
        s, gpu = structure, structure.gpu
        if s.layout != "linear":
            raise LdbenchError("structure.source='peel' needs structure.layout='linear'")
        self.gpu, self.res, self.prefix, self.n_lists = gpu, s.res, s.prefix, s.n_lists
        self.max_layers = s.spec.max_layers
        if 8 * self.n_lists > s.ssbo_limit:
            raise LdbenchError(f"depth peeling {s.layers} LDIs of {s.width}x{s.height} pixels needs "
                               f"{8 * self.n_lists / 2**20:.0f} MiB per-pixel key arrays, above this GPU's SSBO limit "
                               f"of {s.ssbo_limit / 2**20:.0f} MiB")
        self.max_scratch = s.ssbo_limit // 8
        self.peel_layers = 0
        self.truncated = False
        self.scratch_capacity = 0
        self.scratch = None
        self._scratch_total = self._scratch_overflow = 0
        self._vaos: dict = {}
        self._commit = gpu.compute(GLSL_DIR / "layered/peel_commit.glsl")
        self._ends = gpu.compute(GLSL_DIR / "layered/compact.glsl", {**s.defines(), "COMPACT_ENDS": 1})
        self._scatter = gpu.compute(GLSL_DIR / "layered/compact.glsl", {**s.defines(), "COMPACT_SCATTER": 1})

    # ---- scratch ----------------------------------------------------------------------------------
    def _state(self):
        if self.scratch is None:
            n, r, p = self.n_lists, self.res, self.prefix + "peel."
            self.scratch = {"prev": r.buffer(p + "prev", reserve=8 * n), "cand": r.buffer(p + "cand", reserve=8 * n),
                             "count": r.buffer(p + "count", reserve=4 * n),
                             "counters": r.buffer(p + "counters", reserve=16)}
            self._grow(n)
        return self.scratch

    def _grow(self, needed: int):
        """Scratch list of at least ``needed`` entries, its contents kept (grown by 1.5× at least)."""
        if needed <= self.scratch_capacity or self.scratch_capacity >= self.max_scratch:
            return
        cap = min(max(int(needed), self.scratch_capacity * 3 // 2, 1024), self.max_scratch)  # beyond: overflow
        r, p, s = self.res, self.prefix + "peel.", self.scratch
        old = (s.get("loc"), s.get("frag"))
        loc, frag = self.gpu.ctx.buffer(reserve=8 * cap), self.gpu.ctx.buffer(reserve=8 * cap)
        if old[0] is not None and self.scratch_capacity:
            self.gpu.ctx.copy_buffer(loc, old[0], 8 * self.scratch_capacity)
            self.gpu.ctx.copy_buffer(frag, old[1], 8 * self.scratch_capacity)
        for name, buf in (("loc", loc), ("frag", frag)):
            r.adopt(p + name, buf)  # replaces (and releases) the old buffer
            s[name] = buf
        self.scratch_capacity = cap

    def free_scratch(self):
        """Release the peel's scratch buffers (the structure itself stays valid)."""
        if self.scratch is not None:
            for name in self.scratch:
                self.res.free(self.prefix + "peel." + name)
        self.scratch, self.scratch_capacity = None, 0

    # ---- build --------------------------------------------------------------------------------------
    def run(self, extra: dict, capacity: int):
        raise LdbenchError("structure.source='peel' assembles the arrays itself: it serves no fragment pass")

    def assemble(self, stage):
        """Stages ``peel``, ``scan``, ``scatter`` (``stage(name)`` times each)."""
        st, gpu, ctx, n = self.s, self.gpu, self.gpu.ctx, self.n_lists
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
                    self._peel_pass(p)
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
            ctx.copy_buffer(st.offsets, s["count"], 4 * n)
            st.offsets.write(np.zeros(1, np.uint32).tobytes(), offset=4 * n)
            st.scan.run(st.offsets, n + 1)
            st.total = int(np.frombuffer(self.gpu.read(st.offsets, 4, offset=4 * n), np.uint32)[0])
            if st.total > st.capacity or st.total < st.capacity // 2:
                st.allocate(max(st.total, 1))
            self._write_counters()
            st.bind()
            s["count"].bind_to_storage_buffer(B_COUNT)
            self._ends["n"].value = n
            self._ends.run(_groups(n))
            ctx.memory_barrier()
        with stage("scatter"):
            st.bind()
            for name, b in (("loc", B_LOC), ("frag", B_FRAG)):
                s[name].bind_to_storage_buffer(b)
            st.geo.vbo.bind_to_storage_buffer(B_VERTS)
            st.geo.albedo.bind_to_storage_buffer(B_ALBEDO)
            self._scatter["n"].value = min(total, self.scratch_capacity)
            self._scatter.run(_groups(total))
            ctx.memory_barrier()
        self._scratch_total = total

    def _write_counters(self):
        """The ``linear`` layout's counters; fragments beyond the arrays (the SSBO limit) are overflow."""
        st = self.s
        c = np.zeros(16, np.uint32)
        c[C_CAPACITY] = st.capacity
        c[C_COUNTED] = c[C_FILLED] = min(st.total, 0xFFFFFFFF)
        c[C_OVERFLOW] = max(0, st.total - st.capacity)
        st.counters_buf.write(c.tobytes())

    def _peel_pass(self, p: int):
        """Peel pass ``p`` (1: the nearest depth above the last key, 2: the smallest triangle id at it) of
        every layer at once (``layered/peel.glsl``, the full vertex buffer: triangle ids)."""
        st, ctx = self.s, self.gpu.ctx
        prog = self.gpu.program(GLSL_DIR / "layered/peel.glsl", {**st.defines(), "PEEL_PASS": p})
        key = id(prog)
        if key not in self._vaos:
            self._vaos[key] = st.geo.vao(prog)
        prog["ls_size"].value = (st.width, st.height)
        st.layers_buf.bind_to_storage_buffer(B_LAYERS)
        self.scratch["prev"].bind_to_storage_buffer(B_PREV)
        self.scratch["cand"].bind_to_storage_buffer(B_CAND)
        st.fbo.use()
        st.fbo.viewport = (0, 0, st.width, st.height)
        ctx.disable(ctx.DEPTH_TEST | ctx.CULL_FACE | ctx.BLEND)
        self._vaos[key].render(instances=st.layers)
        ctx.memory_barrier()

    # ---- statistics ---------------------------------------------------------------------------------
    def stats(self) -> dict:
        return {"peel_layers": self.peel_layers, "peel_raster_passes": 2 * (self.peel_layers + 1),
                "peel_truncated": self.truncated, "peel_scratch_fragments": self._scratch_total,
                "peel_scratch_overflow": self._scratch_overflow}

    def invariants(self, stats: dict) -> list[str]:
        out = []
        if stats.get("peel_truncated"):
            out.append(f"depth peeling stopped at max_layers = {self.max_layers} with fragments left")
        if stats.get("peel_scratch_overflow"):
            out.append(f"{stats['peel_scratch_overflow']} peeled fragments beyond the scratch list")
        if stats.get("peel_scratch_fragments") != stats.get("fragments"):
            out.append(f"{stats.get('peel_scratch_fragments')} peeled fragments != {stats.get('fragments')} "
                       f"counted by the offsets")
        return out
