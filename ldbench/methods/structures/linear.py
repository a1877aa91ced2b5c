"""Linearised per-texel arrays (archer2019 §3): the ``linear`` layout of :mod:`ldbench.methods.structures`.

A texel's fragments are contiguous in one depth array (and a parallel payload array), so a list is
read with unit stride and its length is known without a walk. Build, per frame (stages):

``count``  clear the per-list counts, rasterize, ``atomicAdd(count[list], 1)`` per fragment.
``scan``   GPU exclusive prefix sum over all ``layers × W × H`` counts + 1 (:class:`ldbench.methods.scan.Scan`):
           offsets, and the total in the last entry, which is read back to size the arrays
           (policy ``grow``: re-allocate when too small, shrink when more than twice too large;
           ``fixed``: ``pool_capacity`` fragments, overflow reported, no read-back; ``lazy``: no
           read-back either, the arrays sized when the next build starts from this build's total, which
           has completed by then — the first build is sized as ``grow``; a build that overflows is
           reported, the next one fits).
``fill``   rasterize again; each fragment takes ``slot = atomicAdd(offset[list], 1)`` and writes its depth
           and payload there. Afterwards ``offset[list]`` is the end of the list, i.e. the beginning of
           the next one, so no second offset array is kept.
``sort``   one thread per list: insertion sort in registers up to ``max_list`` fragments, an exact
           in-place insertion sort in global memory for longer lists (counted).

``assembly = "sort"`` (:meth:`LinearisedArrays.build_sorted`): one fragment pass (any source) appends
every fragment as a pair (list id, depth, payload words) and counts it in its list; an exclusive scan of
the counts, a scatter of the pairs into their lists (a counting sort by list id,
``ldbench/methods/glsl/layered/pairs_scatter.glsl``, stage ``fill``) and the per-list depth sort give the same contiguous
sorted lists as the count → scan → fill → sort build with one fragment pass instead of two, and no
compare-and-swap anywhere. Stages ``emit``, ``scan``, ``fill``, ``sort``; the pairs hold ``capacity``
fragments, sized from the emitted count as above.

``spec.canonical``: a last stage ``canon`` orders the fragments at equal depth by their payload words
(``ldbench/methods/glsl/layered/canon.glsl``), so that every source gives the same structure bit for bit (the
LDIs of niessner2010). A source that assembles the arrays itself (``peel``,
:mod:`ldbench.methods.structures.peel`) replaces count → scan → fill → sort.

Invariants: fragments filled = fragments counted (the end of the last list equals the total), no
overflow unless the pool is ``fixed``, every list sorted.
"""
from __future__ import annotations

import numpy as np

from ldbench.core.bindings import B
from ldbench.core.errors import LdbenchError
from ldbench.core.gpu import GLSL_DIR

from ldbench.methods.scan import Scan

from .core import B_COUNTERS, B_HEADS, B_LAYERS, B_NODES0, B_PAYLOAD, LayeredStructure, fill_uint

C_COUNTED, C_SORT_LONG, C_NONEMPTY, C_MAXLEN, C_UNSORTED, C_FILLED, C_EMITTED, C_OVERFLOW = range(8)


class LinearisedArrays(LayeredStructure):
    """``layers`` images of ``width × height`` contiguous depth lists (see the module docstring).

    The spec's fields used (:class:`~ldbench.methods.structures.spec.StructureSpec`): ``pool`` (``grow``: sized
    from the scanned total every frame; ``fixed``: ``pool_capacity``; ``lazy``: sized from the previous
    build's total, no read-back inside a build), ``pool_capacity`` (first size for ``grow``; 0 = 1 per
    texel), ``max_list`` (register-array length of the sort pass; longer lists: exact global-memory sort),
    ``assembly``, ``canonical``.
    """

    layout = "linear"

    def __init__(self, gpu, geometry, res, spec, *, layers: int, width: int, height: int | None = None,
                 prefix: str = "la."):
        super().__init__(gpu, geometry, res, spec, layers=layers, width=width, height=height, prefix=prefix)
        if spec.pool not in ("grow", "fixed", "lazy"):
            raise LdbenchError(f"structure.pool={spec.pool!r} needs the linked layout")
        self.pool, self.max_list = spec.pool, spec.max_list
        self.max_capacity = self.ssbo_limit // 4 // max(1, len(self.payload))
        self.offsets = res.buffer(prefix + "offsets", reserve=4 * (self.n_lists + 1))
        self.scan = Scan(gpu, res, prefix + "scan.")
        self.depth_buf = self.payload_buf = self.pairs = None
        self.capacity = 0
        self.total = 0
        self._built, self._shrink_to = False, 0
        self.allocate(spec.pool_capacity if spec.pool_capacity > 0 else self.n_lists)

    def allocate(self, capacity: int):
        sort = self.assembly == "sort"
        if sort:  # (list, depth, payload) pairs within one SSBO
            self.max_capacity = min(self.max_capacity, self.ssbo_limit // (4 * (2 + len(self.payload))))
        cap = max(1, min(int(capacity), self.max_capacity))
        self.depth_buf = self.res.buffer(self.prefix + "depth", reserve=4 * cap)
        if self.payload:
            self.payload_buf = self.res.buffer(self.prefix + "payload", reserve=4 * len(self.payload) * cap)
        if sort:
            self.pairs = self.res.buffer(self.prefix + "pairs", reserve=4 * (2 + len(self.payload)) * cap)
        elif self.pairs is not None:
            self.res.free(self.prefix + "pairs")
            self.pairs = None
        self.capacity = cap

    def bind(self):
        self.counters_buf.bind_to_storage_buffer(B_COUNTERS)
        self.offsets.bind_to_storage_buffer(B_HEADS)
        self.layers_buf.bind_to_storage_buffer(B_LAYERS)
        self.depth_buf.bind_to_storage_buffer(B_NODES0)
        if self.payload_buf is not None:
            self.payload_buf.bind_to_storage_buffer(B_PAYLOAD)
        if self.pairs is not None:  # the sort assembly's (list, depth, payload) pairs
            self.pairs.bind_to_storage_buffer(B.PAIRS)

    def build(self, stage=None):
        """Build all layers; stages ``count``, ``scan``, ``fill``, ``sort`` (``stage(name)`` times each;
        the sort assembly: ``emit``, ``scan``, ``fill``, ``sort``)."""
        stage = stage or self.gpu.stage
        n = self.n_lists
        sync = self.pool == "grow" or (self.pool == "lazy" and not self._built)
        if self.pool == "lazy" and self._built:  # the previous build's count: it has completed, no stall
            need = (int(self.read_counters()[C_EMITTED]) if self.assembly == "sort"
                    else int(np.frombuffer(self.gpu.read(self.offsets, 4, offset=4 * n), np.uint32)[0]))
            self.resize_pool(need)
        elif self._shrink_to:
            self.allocate(self._shrink_to)
        self._shrink_to = 0
        self._built = True
        if self.source.assembles:
            self.source.assemble(stage)
        elif self.assembly == "sort":
            self.build_sorted(stage, sync)
        else:
            self.build_direct(stage, sync)
        if self.spec.canonical:
            with stage("canon"):
                self.canonicalize()

    def build_direct(self, stage, sync: bool):
        """count → scan → fill → sort; ``sync``: read the total back and size the arrays from it."""
        n = self.n_lists
        with stage("count"):
            fill_uint(self.gpu, self.offsets, n + 1, 0)
            self.reset_counters(self.capacity)
            self.fragment_pass({"LS_PASS_COUNT": 1}, self.capacity)
        with stage("scan"):
            self.scan.run(self.offsets, n + 1)
            if sync:
                self.total = int(np.frombuffer(self.gpu.read(self.offsets, 4, offset=4 * n), np.uint32)[0])
                if self.total > self.capacity or self.total < self.capacity // 2:
                    self.allocate(max(self.total, 1))
        with stage("fill"):
            self.reset_counters(self.capacity)
            self.fragment_pass({}, self.capacity)
        with stage("sort"):
            self.sort_lists()

    def canonicalize(self):
        """Order fragments at equal depth by payload (``layered/canon.glsl``)."""
        cs = self.gpu.compute(GLSL_DIR / "layered/canon.glsl", self.defines())
        cs["n_lists"].value = self.n_lists
        self.bind()
        cs.run(min(-(-self.n_lists // 64), 8192))
        self.gpu.ctx.memory_barrier()

    # ---- the sort assembly ------------------------------------------------------------------------
    def _emit(self):
        fill_uint(self.gpu, self.offsets, self.n_lists + 1, 0)
        self.reset_counters(self.capacity)
        self.fragment_pass({"LS_EMIT": 1, **aggregate_defines(self.gpu)}, self.capacity)

    def emitted(self) -> int:
        """Fragments the last emit pass appended (stored or not; a read-back)."""
        return int(self.read_counters()[C_EMITTED])

    def build_sorted(self, stage, sync: bool):
        """The sort assembly (module docstring). ``sync``: read the emitted count back and redo the emit
        when the pairs did not fit (``grow``)."""
        n = self.n_lists
        with stage("emit"):
            self._emit()
            if sync:
                self.refit_after_build(self.emitted(), self._emit)
        with stage("scan"):
            self.scan.run(self.offsets, n + 1)
        with stage("fill"):
            cs = self.gpu.compute(GLSL_DIR / "layered/pairs_scatter.glsl", self.defines())
            self.bind()
            cs.run(max(1, min(-(-self.capacity // 256), 65535)))
            self.gpu.ctx.memory_barrier()
        with stage("sort"):
            self.sort_lists()

    def list_counts(self) -> np.ndarray:
        """Fragments per list (layer-major, OpenGL rows), from the offsets (a read-back): comparing two
        builds' counts gives the fragments one misses and adds (the one-pass raster's loss)."""
        off = np.frombuffer(self.gpu.read(self.offsets, 4 * self.n_lists), np.uint32).astype(np.int64)
        return np.diff(np.concatenate([[0], np.minimum(off, self.capacity)]))

    def sort_lists(self):
        """Per-list depth sort (``layered/linear_sort.glsl``)."""
        cs = self.gpu.compute(GLSL_DIR / "layered/linear_sort.glsl", {**self.defines(), "LA_MAX_LIST": self.max_list})
        cs["n_lists"].value = self.n_lists
        self.bind()
        cs.run(min(-(-self.n_lists // 64), 8192))
        self.gpu.ctx.memory_barrier()

    def stats(self) -> dict:
        """Counters of the last build (a statistics pass and a read-back; not for timed regions).

        fragments (counted; the sort assembly: emitted), fragments_stored, pool_capacity, overflow, lists,
        lists_nonempty, mean_list_length, max_list_length, unsorted_lists, linked_nodes (fragments
        reachable through the offsets: the end of the last list, must equal fragments_stored),
        sort_overflow_lists, and :meth:`~ldbench.methods.structures.core.LayeredStructure.build_stats`.
        """
        c = self.stats_pass("layered/linear_stats.glsl", C_NONEMPTY, C_UNSORTED)
        ends = np.frombuffer(self.gpu.read(self.offsets, 8, offset=4 * (self.n_lists - 1)), np.uint32)
        filled, total = int(ends[0]), int(ends[1])
        overflow = int(c[C_OVERFLOW])
        stored = min(total, self.capacity)
        nonempty = int(c[C_NONEMPTY])
        return {
            **self.build_stats(),
            "layout": self.layout,
            "fragments": int(c[C_EMITTED]) if self.assembly == "sort" else total,
            "fragments_stored": stored,
            "pool_capacity": self.capacity,
            "overflow": overflow,
            "overflowed": overflow > 0,
            "lists": self.n_lists,
            "lists_nonempty": nonempty,
            "mean_list_length": stored / nonempty if nonempty else 0.0,
            "max_list_length": int(c[C_MAXLEN]),
            "unsorted_lists": int(c[C_UNSORTED]),
            "linked_nodes": min(filled, self.capacity),
            "sort_overflow_lists": int(c[C_SORT_LONG]),
        }

    def lists(self, payload: bool = False) -> list:
        off = np.frombuffer(self.gpu.read(self.offsets), np.uint32).astype(np.int64)
        depth = np.frombuffer(self.gpu.read(self.depth_buf), np.float32)
        words = (np.frombuffer(self.gpu.read(self.payload_buf), np.uint32).reshape(-1, len(self.payload))
                 if payload and self.payload_buf is not None else None)
        begin = np.concatenate([[0], off[:-2]])
        end = off[:-1]
        out, i = [], 0
        for k in range(self.layers):
            rows = []
            for y in range(self.height):
                row = []
                for x in range(self.width):
                    b, e = min(begin[i], self.capacity), min(end[i], self.capacity)
                    row.append([float(depth[j]) if words is None else (float(depth[j]), tuple(words[j]))
                                for j in range(b, e)])
                    i += 1
                rows.append(row)
            out.append(rows)
        return out


def aggregate_defines(gpu) -> dict:
    """``LL_AGGREGATE`` where the driver has subgroup ballots (the emit pass's aggregated append)."""
    ext = gpu.ctx.extensions
    return {"LL_AGGREGATE": 1} if "GL_ARB_shader_ballot" in ext and "GL_ARB_gpu_shader_int64" in ext else {}
