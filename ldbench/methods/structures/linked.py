"""Layered per-pixel linked lists on the GPU (yang2010 §3): the ``linked`` layout of :mod:`ldbench.methods.structures`.

:class:`LayeredLinkedLists` holds ``layers`` maps of ``width × height`` per-pixel linked lists, e.g. the
N orthographic layered depth maps (LDMs) of aalund2015, in one head buffer and one node pool:

- **heads**: one ``uint`` per list (``layers × height × width``, layer-major, OpenGL rows), initialised
  to the end-of-list value ``LL_EOL = 0xFFFFFFFF`` by a compute pass every build.
- **node pool**: 8-byte nodes ``{float depth; uint next}`` (one load per step of a list walk), split
  into up to 4 SSBO *pages* so that no buffer exceeds ``GL_MAX_SHADER_STORAGE_BLOCK_SIZE`` (128 MiB on
  some drivers, 2 GiB on current NVIDIA); node ``i`` lives in page ``i >> page_shift``.
- **counter**: ``atomicAdd`` on an SSBO ``uint`` (moderngl has no atomic-counter-buffer helper). It
  *saturates* at the capacity: an allocation past it undoes its add and increments a separate overflow
  counter, so the node counter can never wrap past 2³² and hand out live nodes again. After a build
  ``fragments = nodes + overflow``: overflow is always detected and reported, never silent.

Node allocation is one ``atomicAdd`` per fragment, or with ``aggregate=True`` one per subgroup
(``ARB_shader_ballot``: the subgroup's leader adds the number of active invocations, each invocation
takes base + its rank), which removes most of the contention on the single counter address.

The fragment pass, layer transforms and payload words are those of :mod:`ldbench.methods.structures.core`.

Insert algorithm (``sorted_insert``):

- ``True`` (default, aalund2015's pre-sorted lists, "PSPPSLL"): a **lock-free sorted insert**. The new
  node walks its list to the first node with depth ≥ its own, links itself in front of it and publishes
  itself with ``atomicCompSwap`` on the predecessor's ``next`` (or on the head). A failed CAS means
  another fragment was linked in exactly there; the walk resumes from the same predecessor at the node
  the CAS returned. This is correct because nodes are only ever inserted, never removed or moved (the
  predecessor stays valid and stays in front of the new depth), and it is lock-free: every failed CAS
  is some other fragment's successful insert. We chose it over per-pixel spin locks because a spin lock
  in a fragment shader can deadlock on SIMT GPUs when the lock holder and a waiter sit in the same
  warp and the scheduler keeps running the waiting branch; a CAS retry loop never waits on another
  thread. Memory: ``coherent`` buffers and a ``memoryBarrierBuffer()`` between writing the node and the
  CAS that publishes it.
- ``False``: yang2010's insert (``atomicExchange`` on the head, lists in arrival order), followed by a
  **sort pass**: one compute thread per list insertion-sorts up to ``max_list`` depths into a local array
  as it walks the list and writes them back along a second walk of the same chain (with a payload: the
  node indices kept, node contents swapped by a selection sort). Lists longer than ``max_list`` are
  counted (``sort_overflow_lists``) and sorted in place in global memory (selection sort over the
  chain), so results stay exact. We sort once per list after the build rather than on every read,
  because an LDM list is read by many shading pixels (the aalund2015 trace reads one list per pixel
  per direction); both variants then give the same sorted lists.

Pool sizing (``pool``):

- ``"grow"`` (default): build into the current pool and read back the counter; if it exceeds the
  capacity, re-allocate exactly the count and redo the build (``build_passes`` = 2 in that frame).
  A pool more than twice too large is shrunk to the count before the next build. For a static scene
  the steady state is one raster pass and an exact pool. First size: ``pool_capacity`` or 1 node per
  list.
- ``"count"``: a counting pass (same raster, the fragment shader only does ``atomicAdd``), read back
  the count, allocate exactly that many nodes (re-allocating when the count grows or falls below half
  the capacity) and build: two raster passes every frame, never a redo (the policy for dynamic scenes
  whose fragment count changes every frame).
- ``"fixed"``: ``pool_capacity`` nodes, never resized; overflow is reported, not repaired.
- ``"lazy"``: no read-back inside a build. The pool is sized when the *next* build starts, from this
  build's count (nodes + overflow), which has completed by then: no stall on the frame being built.
  The first build is sized as ``"grow"``; a build that overflows (the scene grew) is reported by the
  invariants and the next one fits. For a static scene: one raster pass, an exact pool, no read-back.

Hard limits: 4 pages of ``page_nodes`` each (beyond: overflow reported) and ``layers × width × height``
heads within one SSBO. Every list walk in GLSL (insert, sort, statistics, tracers) is bounded by the
pool capacity, so a corrupt link shows as a violated invariant instead of hanging the GPU.
"""
from __future__ import annotations

import numpy as np

from ldbench.core.errors import LdbenchError
from ldbench.core.gpu import GLSL_DIR

from .core import B_COUNTERS, B_HEADS, B_LAYERS, B_NODES0, B_PAYLOAD, LayeredStructure, fill_uint

EOL = 0xFFFFFFFF
MAX_PAGES = 4
NODE_BYTES = 8
NODE_DTYPE = np.dtype([("depth", "<f4"), ("next", "<u4")])
# counter indices (ldbench/methods/glsl/layered/linked_list.glsl)
C_NODES, C_SORT_LONG, C_NONEMPTY, C_MAXLEN, C_UNSORTED, C_LINKED, C_FAILED, C_OVERFLOW = range(8)


def _floor_pow2(x: int) -> int:
    return 1 << (int(x).bit_length() - 1)


class LayeredLinkedLists(LayeredStructure):
    """``layers`` maps of ``width × height`` per-pixel linked lists (see the module docstring).

    The spec's fields used (:class:`~ldbench.methods.structures.spec.StructureSpec`): ``sorted_insert`` (lock-free
    sorted insert, or yang2010 insert + sort pass), ``pool`` and ``pool_capacity`` (the fixed size, or the
    first size for ``grow`` and ``lazy``; 0 = 1 node per list), ``max_list`` (local array of the sort pass),
    ``page_nodes`` (nodes per SSBO page; 0 = from the driver's SSBO size limit), ``aggregate``
    (warp-aggregated node allocation, ``ARB_shader_ballot``: one ``atomicAdd`` per subgroup).
    """

    layout = "linked"

    def __init__(self, gpu, geometry, res, spec, *, layers: int, width: int, height: int | None = None,
                 prefix: str = "ll."):
        super().__init__(gpu, geometry, res, spec, layers=layers, width=width, height=height, prefix=prefix)
        if spec.assembly != "direct":
            raise LdbenchError(f"structure.assembly={spec.assembly!r} needs the linear layout")
        self.sorted_insert, self.pool, self.max_list = spec.sorted_insert, spec.pool, spec.max_list
        self.aggregate = spec.aggregate
        if self.aggregate:
            missing = [e for e in ("GL_ARB_shader_ballot", "GL_ARB_gpu_shader_int64")
                       if e not in gpu.ctx.extensions]
            if missing:
                raise LdbenchError(f"warp-aggregated atomics need {' and '.join(missing)}, "
                                   "which this OpenGL driver lacks: set structure.aggregate=false")
        limit = self.ssbo_limit
        pn = min(_floor_pow2(max(limit // NODE_BYTES, 1)), 1 << 30) if not spec.page_nodes else spec.page_nodes
        self.page_nodes, self.page_shift = pn, pn.bit_length() - 1
        self.max_capacity = min(MAX_PAGES * pn, EOL - 1)
        if self.payload:
            self.max_capacity = min(self.max_capacity, limit // (4 * len(self.payload)))
        self.heads = res.buffer(prefix + "heads", reserve=4 * self.n_lists)
        self.node_pages: list = []
        self.payload_buf = None
        self.capacity = 0
        first = spec.pool_capacity if spec.pool_capacity > 0 else self.n_lists
        self.allocate(first if self.pool != "count" else 1)
        self._shrink_to = 0
        self.build_passes = 0
        self._built = False

    # ---- allocation ------------------------------------------------------------------------
    def allocate(self, capacity: int):
        """Pool of ``capacity`` nodes (clamped to the page limit; the clamp shows as overflow)."""
        cap = max(1, min(int(capacity), self.max_capacity))
        pages = -(-cap // self.page_nodes)
        for p in range(pages):
            n = self.page_nodes if p < pages - 1 else cap - (pages - 1) * self.page_nodes
            if p < len(self.node_pages) and self.node_pages[p].size == NODE_BYTES * n:
                continue
            buf = self.res.buffer(f"{self.prefix}nodes{p}", reserve=NODE_BYTES * n)
            if p < len(self.node_pages):
                self.node_pages[p] = buf
            else:
                self.node_pages.append(buf)
        for p in range(pages, len(self.node_pages)):  # pages no longer needed are released
            self.res.free(f"{self.prefix}nodes{p}")
        del self.node_pages[pages:]
        if self.payload:
            self.payload_buf = self.res.buffer(f"{self.prefix}payload", reserve=4 * len(self.payload) * cap)
        self.pages = pages
        self.capacity = cap

    def defines(self) -> dict:
        return {**super().defines(), "LL_PAGES": self.pages, "LL_PAGE_SHIFT": self.page_shift}

    def bind(self):
        """Bind counters, heads, layer transforms, node pages and payload to their SSBO bindings."""
        self.counters_buf.bind_to_storage_buffer(B_COUNTERS)
        self.heads.bind_to_storage_buffer(B_HEADS)
        self.layers_buf.bind_to_storage_buffer(B_LAYERS)
        for p in range(self.pages):
            self.node_pages[p].bind_to_storage_buffer(B_NODES0 + p)
        if self.payload_buf is not None:
            self.payload_buf.bind_to_storage_buffer(B_PAYLOAD)

    # ---- passes ----------------------------------------------------------------------------
    def _pass_defines(self, count_only: bool) -> dict:
        d = {"LL_AGGREGATE": 1} if self.aggregate else {}
        if count_only:
            d["LS_PASS_COUNT"] = 1
        elif self.sorted_insert:
            d["LL_SORTED"] = 1
        return d

    def _clear_heads(self):
        fill_uint(self.gpu, self.heads, self.n_lists, EOL)

    def read_counter(self) -> int:
        """Fragments of the last pass: nodes handed out plus allocations refused (needs a read-back)."""
        c = self.read_counters()
        return int(c[C_NODES]) + int(c[C_OVERFLOW])

    def count(self) -> int:
        """Counting pass: the number of fragments a build will insert (needs a read-back)."""
        self.reset_counters(self.capacity)
        self.fragment_pass(self._pass_defines(count_only=True), 0)
        return self.read_counter()

    def build(self, stage=None, sort: bool = True):
        """Build all layers. ``stage(name)`` is a context manager timing a stage (default
        ``gpu.stage``): ``count`` (policy "count"), ``build`` and, for the unsorted variant, ``sort``.
        ``sort=False`` leaves the unsorted variant's lists in arrival order for a consumer that sorts
        while it reads (yang2010's OIT resolve, ldbench/methods/ll_oit)."""
        stage = stage or self.gpu.stage
        self.build_passes = 0
        if self.pool == "count":
            with stage("count"):
                n = self.count()
                self.resize_pool(n)
        elif self.pool == "grow" and self._shrink_to:
            self.allocate(self._shrink_to)
            self._shrink_to = 0
        elif self.pool == "lazy" and self._built:  # the previous build's count: it has completed, no stall
            self.resize_pool(self.read_counter())
        sync = self.pool == "grow" or (self.pool == "lazy" and not self._built)
        self._built = True
        with stage("build"):
            self._build_once()
            if sync:
                self.refit_after_build(self.read_counter(), self._build_once)
        if not self.sorted_insert and sort:
            with stage("sort"):
                self.sort()

    def _build_once(self):
        self._clear_heads()
        self.reset_counters(self.capacity)
        self.fragment_pass(self._pass_defines(count_only=False), self.capacity)
        self.build_passes += 1

    def sort(self):
        """Sort every list in place by ascending depth (for lists built unsorted); after a pass whose
        source sorted most lists itself (``structure.splat_sort``), only the lists it left."""
        left = self.source.unsorted_lists() if self.source is not None else None
        listed = {"LL_SORT_LISTED": 1} if left is not None else {}
        cs = self.gpu.compute(GLSL_DIR / "layered/linked_list_sort.glsl",
                              {**self.defines(), "LL_MAX_LIST": self.max_list, **listed})
        if "n_lists" in cs:
            cs["n_lists"].value = self.n_lists
        self.bind()
        if left is not None:
            left.bind_sort(cs)
        n = left.sort_cap if left is not None else self.n_lists
        cs.run(min(-(-n // 64), 65535))
        self.gpu.ctx.memory_barrier()

    # ---- read-back ---------------------------------------------------------------------------
    def stats(self) -> dict:
        """Counters of the last build (runs a statistics pass and reads back; not for timed regions).

        fragments: attempted inserts; fragments_stored; pool_capacity (nodes); overflow (fragments not
        stored: pool full); overflowed; lists (total); lists_nonempty; mean_list_length (over non-empty
        lists); max_list_length; unsorted_lists (0 after a correct build); linked_nodes (nodes reached
        from the heads: equals fragments_stored); sort_overflow_lists (lists longer than max_list met
        by the sort pass); insert_failures (sorted inserts abandoned: lost LL_MAX_RETRIES races or a walk
        past the capacity bound; expected 0); build_passes; pages.
        """
        c = self.stats_pass("layered/linked_list_stats.glsl", C_NONEMPTY, C_LINKED)
        failures, overflow = int(c[C_FAILED]), int(c[C_OVERFLOW])
        nodes = int(c[C_NODES])
        stored = nodes - failures
        nonempty = int(c[C_NONEMPTY])
        return {
            **self.build_stats(),
            "layout": self.layout,
            "fragments": nodes + overflow,
            "fragments_stored": stored,
            "pool_capacity": self.capacity,
            "overflow": overflow,
            "overflowed": overflow > 0,
            "lists": self.n_lists,
            "lists_nonempty": nonempty,
            "mean_list_length": float(c[C_LINKED]) / nonempty if nonempty else 0.0,
            "max_list_length": int(c[C_MAXLEN]),
            "unsorted_lists": int(c[C_UNSORTED]),
            "linked_nodes": int(c[C_LINKED]),
            "sort_overflow_lists": int(c[C_SORT_LONG]),
            "insert_failures": failures,
            "build_passes": self.build_passes,
            "pages": self.pages,
        }

    def read(self):
        """(heads (layers, H, W) uint32 with row 0 = OpenGL's bottom row, depth (capacity,) f4,
        next (capacity,) u4) — for tests and debugging."""
        heads = np.frombuffer(self.gpu.read(self.heads), np.uint32).reshape(self.layers, self.height, self.width)
        nodes = np.concatenate([np.frombuffer(self.gpu.read(self.node_pages[p]), NODE_DTYPE)
                                for p in range(self.pages)])
        return heads, nodes["depth"].copy(), nodes["next"].copy()

    def lists(self, payload: bool = False) -> list:
        heads, depth, nxt = self.read()
        words = (np.frombuffer(self.gpu.read(self.payload_buf), np.uint32).reshape(-1, len(self.payload))
                 if payload and self.payload_buf is not None else None)
        out = []
        for k in range(self.layers):
            rows = []
            for y in range(self.height):
                row = []
                for x in range(self.width):
                    i = int(heads[k, y, x])
                    vals: list[float | tuple[float, tuple]] = []  # depths, or (depth, payload words)
                    while i != EOL and len(vals) <= self.capacity:
                        vals.append(float(depth[i]) if words is None else (float(depth[i]), tuple(words[i])))
                        i = int(nxt[i])
                    row.append(vals)
                rows.append(row)
            out.append(rows)
        return out
