"""Layered per-pixel linked lists on the GPU (yang2010 §3): the building block of the LDM methods.

:class:`LayeredLinkedLists` holds ``layers`` maps of ``width × height`` per-pixel linked lists, e.g. the
N orthographic layered depth maps (LDMs) of aalund2015, in one head buffer and one node pool:

- **heads**: one ``uint`` per list (``layers × height × width``, layer-major, OpenGL rows), initialised
  to the end-of-list value ``LL_EOL = 0xFFFFFFFF`` by a compute pass every build.
- **node pool**: 8-byte nodes ``{float depth; uint next}`` (one load per step of a list walk), split
  into up to 4 SSBO *pages* so that no buffer exceeds ``GL_MAX_SHADER_STORAGE_BLOCK_SIZE`` (128 MiB on
  some drivers, 2 GiB on current NVIDIA); node ``i`` lives in page ``i >> page_shift``.
- **counter**: ``atomicAdd`` on an SSBO ``uint`` (moderngl has no atomic-counter-buffer helper). Every
  fragment increments it, stored or not, so after a build ``fragments = counter`` and
  ``stored = min(counter, capacity)``: overflow is always detected and reported, never silent.

Node allocation is one ``atomicAdd`` per fragment, or with ``aggregate=True`` one per subgroup
(``ARB_shader_ballot``: the subgroup's leader adds the number of active invocations, each invocation
takes base + its rank), which removes most of the contention on the single counter address.

One geometry pass inserts every fragment of every layer: a single instanced draw with
``gl_InstanceID`` = layer (the vertex shader applies that layer's clip transform from an SSBO), or, with
``instanced=False``, one draw per layer. Depth test, face culling and colour writes are off (both faces
of every triangle land in the lists); the fragment shader has no ``early_fragment_tests``.

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
  **sort pass**: one compute thread per list gathers up to ``max_list`` depths into a local array,
  insertion-sorts them and writes them back along the same chain. Lists longer than ``max_list`` are
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

Hard limits: 4 pages of ``page_nodes`` each (beyond: overflow reported), a 32-bit counter (4 G
fragment attempts per build) and ``layers × width × height`` heads within one SSBO.

Depth: each layer ``k`` has a clip transform ``clip[k]`` (world → clip, for the raster) and a depth row
``depth_row[k]``; the stored depth is ``dot(depth_row, (p, 1))`` of the fragment's world position p
(interpolated perspective-correctly, so any depth linear in world space is exact).
"""
from __future__ import annotations

import numpy as np

from harness.errors import LdbenchError
from harness.gpu import GLSL_DIR

EOL = 0xFFFFFFFF
MAX_PAGES = 4
POLICIES = ("grow", "count", "fixed")
# SSBO bindings (methods/glsl/linked_list.glsl)
B_COUNTERS, B_HEADS, B_LAYERS, B_NODES0 = 0, 1, 2, 3
NODE_BYTES = 8
NODE_DTYPE = np.dtype([("depth", "<f4"), ("next", "<u4")])
N_COUNTERS = 8


def _floor_pow2(x: int) -> int:
    return 1 << (int(x).bit_length() - 1)


class LayeredLinkedLists:
    """``layers`` maps of ``width × height`` per-pixel linked lists (see the module docstring).

    Parameters
    ----------
    gpu, geometry, res : the :class:`~harness.gpu.Gpu`, the :class:`~methods.gbuffer.SceneGeometry` to
        rasterize, and the :class:`~harness.gpu.Resources` that accounts for the buffers.
    layers, width, height : number of maps and their size in texels.
    sorted_insert : lock-free sorted insert (True) or yang2010 insert + sort pass (False).
    pool : ``"grow"``, ``"count"`` or ``"fixed"``; ``pool_capacity`` is the fixed size, or the initial
        size for ``"grow"`` (0 = 1 node per list).
    max_list : local-array size of the sort pass (unsorted variant).
    instanced : one instanced draw for all layers (True) or one draw per layer.
    page_nodes : nodes per SSBO page (a power of two; default from the driver's SSBO size limit).
    indexed : rasterize the shared indexed position-only geometry (vertex shader once per vertex
        and layer) instead of the non-indexed triangle list; same triangles, same fragments.
    aggregate : warp-aggregated node allocation (``ARB_shader_ballot``): one ``atomicAdd`` on the
        counter per subgroup instead of one per fragment.
    """

    def __init__(self, gpu, geometry, res, *, layers: int, width: int, height: int | None = None,
                 sorted_insert: bool = True, pool: str = "grow", pool_capacity: int = 0,
                 max_list: int = 64, instanced: bool = True, page_nodes: int | None = None,
                 aggregate: bool = False, indexed: bool = True, prefix: str = "ll."):
        if pool not in POLICIES:
            raise LdbenchError(f"linked-list pool policy {pool!r} not one of {list(POLICIES)}")
        if pool == "fixed" and pool_capacity < 1:
            raise LdbenchError("linked-list pool 'fixed' needs pool_capacity >= 1")
        self.gpu, self.geo, self.res, self.prefix = gpu, geometry, res, prefix
        self.layers, self.width = int(layers), int(width)
        self.height = int(height if height is not None else width)
        self.sorted_insert, self.pool, self.max_list = bool(sorted_insert), pool, int(max_list)
        self.instanced = bool(instanced)
        self.indexed = bool(indexed)
        self.aggregate = bool(aggregate)
        if self.aggregate:
            missing = [e for e in ("GL_ARB_shader_ballot", "GL_ARB_gpu_shader_int64")
                       if e not in gpu.ctx.extensions]
            if missing:
                raise LdbenchError(f"warp-aggregated atomics need {' and '.join(missing)}, "
                                   "which this OpenGL driver lacks")
        self.n_lists = self.layers * self.width * self.height
        limit = int(gpu.ctx.info.get("GL_MAX_SHADER_STORAGE_BLOCK_SIZE") or (1 << 27))
        if self.n_lists * 4 > limit:
            raise LdbenchError(
                f"{self.layers} layers of {self.width}x{self.height} lists need a head buffer of "
                f"{self.n_lists * 4 / 2**20:.0f} MiB, above this GPU's SSBO limit of {limit / 2**20:.0f} MiB")
        pn = min(_floor_pow2(max(limit // NODE_BYTES, 1)), 1 << 30) if page_nodes is None else int(page_nodes)
        if pn < 1 or pn & (pn - 1) or pn > 1 << 30:
            raise LdbenchError(f"page_nodes must be a power of two, got {page_nodes}")
        self.page_nodes, self.page_shift = pn, pn.bit_length() - 1
        self.max_capacity = min(MAX_PAGES * pn, EOL - 1)
        self.counters_buf = res.buffer(prefix + "counters", reserve=4 * N_COUNTERS)
        self.heads = res.buffer(prefix + "heads", reserve=4 * self.n_lists)
        self.layers_buf = res.buffer(prefix + "layers", reserve=80 * self.layers)
        self.node_pages: list = []
        self.capacity = 0
        first = pool_capacity if pool_capacity > 0 else self.n_lists
        self._allocate(first if pool != "count" else 1)
        self._shrink_to = 0
        self.fbo = gpu.ctx.empty_framebuffer((self.width, self.height))
        self.fragments = 0        # attempted fragments in the last build (-1 = not read back)
        self.build_passes = 0
        self._have_layers = False

    # ---- allocation ------------------------------------------------------------------------
    def _allocate(self, capacity: int):
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
        self.pages = pages
        self.capacity = cap

    def defines(self) -> dict:
        """``#define``s every shader including ``linked_list.glsl`` must be compiled with."""
        return {"LL_PAGES": self.pages, "LL_PAGE_SHIFT": self.page_shift}

    def bind(self):
        """Bind counters, heads, layer transforms and node pages to their SSBO bindings."""
        self.counters_buf.bind_to_storage_buffer(B_COUNTERS)
        self.heads.bind_to_storage_buffer(B_HEADS)
        self.layers_buf.bind_to_storage_buffer(B_LAYERS)
        for p in range(self.pages):
            self.node_pages[p].bind_to_storage_buffer(B_NODES0 + p)

    def set_layers(self, clip: np.ndarray, depth_rows: np.ndarray):
        """Per-layer world→clip matrices (L, 4, 4), column-vector convention, and depth rows (L, 4)."""
        clip = np.asarray(clip, np.float64).reshape(self.layers, 4, 4)
        rows = np.asarray(depth_rows, np.float64).reshape(self.layers, 4)
        data = np.empty((self.layers, 20), np.float32)
        data[:, :16] = clip.transpose(0, 2, 1).reshape(self.layers, 16)  # GLSL column-major
        data[:, 16:] = rows
        self.layers_buf.write(data.tobytes())
        self._have_layers = True

    # ---- passes ----------------------------------------------------------------------------
    def _program(self, count_only: bool):
        d = dict(self.defines())
        if self.aggregate:
            d["LL_AGGREGATE"] = 1
        if count_only:
            d["LL_COUNT_ONLY"] = 1
        elif self.sorted_insert:
            d["LL_SORTED"] = 1
        prog = self.gpu.program(GLSL_DIR / "linked_list_build.glsl", d)
        key = id(prog)
        if getattr(self, "_vaos", None) is None:
            self._vaos = {}
        if key not in self._vaos:
            self._vaos[key] = self.geo.vao_positions(prog) if self.indexed else self.geo.vao(prog)
        return prog, self._vaos[key]

    def _reset_counters(self):
        self.counters_buf.write(np.zeros(N_COUNTERS, np.uint32).tobytes())

    def _raster(self, count_only: bool):
        ctx = self.gpu.ctx
        prog, vao = self._program(count_only)
        if "ll_size" in prog:
            prog["ll_size"].value = (self.width, self.height)
        if "ll_capacity" in prog:
            prog["ll_capacity"].value = self.capacity
        self.bind()
        self.fbo.use()
        self.fbo.viewport = (0, 0, self.width, self.height)
        ctx.disable(ctx.DEPTH_TEST | ctx.CULL_FACE | ctx.BLEND)
        if self.instanced:
            if "layer_base" in prog:
                prog["layer_base"].value = 0
            vao.render(instances=self.layers)
        else:
            for k in range(self.layers):
                prog["layer_base"].value = k
                vao.render()
        ctx.memory_barrier()

    def _clear_heads(self):
        cs = self.gpu.compute(GLSL_DIR / "linked_list_clear.glsl", {**self.defines(), "LL_WRITABLE": 1})
        cs["n"].value = self.n_lists
        self.bind()
        cs.run(min(-(-self.n_lists // 256), 4096))
        self.gpu.ctx.memory_barrier()

    def read_counter(self) -> int:
        return int(np.frombuffer(self.counters_buf.read(size=4), np.uint32)[0])

    def count(self) -> int:
        """Counting pass: the number of fragments a build will insert (needs a read-back)."""
        self._reset_counters()
        self._raster(count_only=True)
        return self.read_counter()

    def build(self, stage=None):
        """Build all layers. ``stage(name)`` is a context manager timing a stage (default
        ``gpu.stage``): ``count`` (policy "count"), ``build`` and, for the unsorted variant, ``sort``."""
        if not self._have_layers:
            raise LdbenchError("LayeredLinkedLists.build: set_layers() was not called")
        stage = stage or self.gpu.stage
        self.build_passes = 0
        if self.pool == "count":
            with stage("count"):
                n = self.count()
                if (n > self.capacity and self.capacity < self.max_capacity) or n < self.capacity // 2:
                    self._allocate(max(n, 1))
        elif self.pool == "grow" and self._shrink_to:
            self._allocate(self._shrink_to)
            self._shrink_to = 0
        with stage("build"):
            self._build_once()
            if self.pool == "grow":
                n = self.read_counter()
                if n > self.capacity and self.capacity < self.max_capacity:
                    self._allocate(n)
                    self._build_once()
                elif n < self.capacity // 2:
                    self._shrink_to = max(n, 1)  # the lists are in use this frame: shrink at the next build
        if not self.sorted_insert:
            with stage("sort"):
                self.sort()

    def _build_once(self):
        self._clear_heads()
        self._reset_counters()
        self._raster(count_only=False)
        self.build_passes += 1

    def sort(self):
        """Sort every list in place by ascending depth (for lists built unsorted)."""
        cs = self.gpu.compute(GLSL_DIR / "linked_list_sort.glsl",
                              {**self.defines(), "LL_MAX_LIST": self.max_list})
        cs["n_lists"].value = self.n_lists
        cs["ll_capacity"].value = self.capacity
        self.bind()
        cs.run(min(-(-self.n_lists // 64), 8192))
        self.gpu.ctx.memory_barrier()

    # ---- read-back ---------------------------------------------------------------------------
    def stats(self) -> dict:
        """Counters of the last build (runs a statistics pass and reads back; not for timed regions).

        fragments: attempted inserts; fragments_stored; pool_capacity (nodes); overflow (fragments not
        stored: pool full or, never expected, a sorted insert that lost LL_MAX_RETRIES races, also counted
        in insert_failures); overflowed; lists (total); lists_nonempty; mean_list_length (over non-empty
        lists); max_list_length; unsorted_lists (0 after a correct build); linked_nodes (nodes reached
        from the heads: equals fragments_stored); sort_overflow_lists (lists longer than max_list met
        by the sort pass); build_passes; pages.
        """
        c = np.frombuffer(self.counters_buf.read(), np.uint32).copy()
        c[2:6] = 0
        self.counters_buf.write(c.tobytes())
        cs = self.gpu.compute(GLSL_DIR / "linked_list_stats.glsl", self.defines())
        cs["n_lists"].value = self.n_lists
        cs["ll_capacity"].value = self.capacity
        self.bind()
        cs.run(min(-(-self.n_lists // 64), 8192))
        self.gpu.ctx.memory_barrier()
        c = np.frombuffer(self.counters_buf.read(), np.uint32)
        failures = int(c[6])
        attempted, stored = int(c[0]), int(min(c[0], self.capacity)) - failures
        nonempty = int(c[2])
        return {
            "fragments": attempted,
            "fragments_stored": stored,
            "pool_capacity": self.capacity,
            "overflow": attempted - stored,
            "overflowed": attempted > stored,
            "lists": self.n_lists,
            "lists_nonempty": nonempty,
            "mean_list_length": float(c[5]) / nonempty if nonempty else 0.0,
            "max_list_length": int(c[3]),
            "unsorted_lists": int(c[4]),
            "linked_nodes": int(c[5]),
            "sort_overflow_lists": int(c[1]),
            "insert_failures": failures,
            "build_passes": self.build_passes,
            "pages": self.pages,
        }

    def read(self):
        """(heads (layers, H, W) uint32 with row 0 = OpenGL's bottom row, depth (capacity,) f4,
        next (capacity,) u4) — for tests and debugging."""
        heads = np.frombuffer(self.heads.read(), np.uint32).reshape(self.layers, self.height, self.width)
        nodes = np.concatenate([np.frombuffer(self.node_pages[p].read(), NODE_DTYPE)
                                for p in range(self.pages)])
        return heads, nodes["depth"].copy(), nodes["next"].copy()

    def lists(self) -> list:
        """Every list as a Python list of depths in link order: ``out[layer][y][x]`` (OpenGL rows)."""
        heads, depth, nxt = self.read()
        out = []
        for k in range(self.layers):
            rows = []
            for y in range(self.height):
                row = []
                for x in range(self.width):
                    i, vals = int(heads[k, y, x]), []
                    while i != EOL and len(vals) <= self.capacity:
                        vals.append(float(depth[i]))
                        i = int(nxt[i])
                    row.append(vals)
                rows.append(row)
            out.append(rows)
        return out

    def memory(self) -> dict:
        """{buffer name: bytes} of this structure's buffers."""
        return {self.res.prefix + k: v for k, v in self.res.bytes.items() if k.startswith(self.prefix)}
