"""What a layered depth structure is: one frozen :class:`StructureSpec` in one vocabulary.

A structure is a ``layout`` (how the fragments are stored) filled from a fragment ``source`` (how they
are found), put in order by an ``assembly``, in a pool sized by the ``pool`` policy; the remaining
fields are the knobs of one layout or source. The spec says *how* to build; the size (layers, texels)
and the layers' transforms come from the method that owns the structure
(:func:`ldbench.methods.structures.factory.make_structure`).

The adapters that keep a structure (``ldm``, ``ldi``, ``cdi-vpl``, ``ll-oit``) nest this class unchanged
as their ``structure`` parameter group (:func:`ldbench.core.params.group`), each exposing the fields it lets a
suite choose; every error names the dotted parameter (``structure.source``).
"""
from __future__ import annotations

from dataclasses import dataclass

from ldbench.core.errors import LdbenchError
from ldbench.core.params import ParamsBase, param

#: ``linked``: per-texel linked lists (yang2010, aalund2015); ``linear``: linearised arrays (archer2019).
#: Compacted depth-peeled layers (niessner2010) are the ``linear`` layout filled by the ``peel`` source.
LAYOUTS = ("linked", "linear")
#: ``raster``: the hardware raster of every layer in its own view; ``one_pass``: one swizzled raster whose
#: fragments are projected into every layer (archer2019, not conservative); ``splat``: a compute rasterizer
#: of the small triangles with the hardware's fill rule (the raster's fragments); ``peel``: depth peeling,
#: one layer of every texel per pair of raster passes, compacted by a prefix sum (niessner2010).
SOURCES = ("raster", "one_pass", "splat", "peel")
#: ``direct``: count → scan → fill → sort (linked: insert); ``sort``: one pass of (list, depth) pairs,
#: scan, scatter by list, sort (linear layout).
ASSEMBLIES = ("direct", "sort")
#: ``grow``: redo a build that overflowed; ``count``: a counting pass first (linked); ``fixed``:
#: ``pool_capacity``, overflow reported; ``lazy``: sized from the previous build, no read-back in a build.
POOLS = ("grow", "count", "fixed", "lazy")
PAYLOAD_WORDS = ("normal", "albedo", "material")
#: how the splat rasterizes its long triangles: ``raster``, one instanced draw of them by the hardware;
#: ``tiles``, a compute pass over tiles of every layer (``layered/splat_tiles.glsl``).
SPLAT_LARGE = ("raster", "tiles")
SPLAT_MAX_LIMIT = 64  # texels: keeps the splat's integer edge functions within int32


@dataclass(frozen=True)
class StructureSpec(ParamsBase):
    """How one layered depth structure is stored and built (module docstring)."""

    prefix = "structure."

    layout: str = param("linked", "per-texel linked lists or linearised arrays (peeled layers: linear)",
                        choices=LAYOUTS)
    source: str = param("raster", "where the fragments come from: raster (the hardware raster of every layer in "
                        "its own view), one_pass (one swizzled raster projected into every layer, archer2019; not "
                        "conservative), splat (a compute rasterizer of the small triangles with the hardware's "
                        "fill rule: the raster's fragments) or peel (depth peeling, niessner2010)",
                        choices=SOURCES)
    assembly: str = param("direct", "how the fragments are put in order: direct (count, scan, fill, sort; linked "
                          "lists: insert) or sort (one pass of (list, depth) pairs, scan, scatter by list, sort; "
                          "linear layout only)", choices=ASSEMBLIES)
    pool: str = param("grow", "how the fragment pool is sized: grow (redo a build that overflowed), count (a "
                      "counting pass first; linked only), fixed (pool_capacity, overflow reported) or lazy (sized "
                      "from the previous build: no read-back inside a build; docs/reference/methods/fast_builds.md)", choices=POOLS)
    pool_capacity: int = param(0, "fragments for pool=fixed (first size for grow and lazy; 0 = 1 per texel)", lo=0)
    sorted_insert: bool = param(True, "linked: lock-free sorted insert (PSPPSLL); False = yang2010 insert + "
                                "sort pass")
    max_list: int = param(64, "register-array length of the sort passes (longer lists take a slow exact path)",
                          lo=1, hi=1024)
    instanced: bool = param(True, "raster: one instanced draw for all layers (False: one draw per layer)")
    aggregate: bool = param(False, "linked: one atomicAdd per subgroup on the node counter (needs "
                            "ARB_shader_ballot: set false on a driver without it)")
    indexed: bool = param(True, "without payload, rasterize the indexed position-only geometry (vertex reuse; "
                          "the same fragments)")
    payload: tuple = param((), "32-bit words stored per fragment besides its depth, any of normal, albedo "
                           "and material, stored in the order given")
    pass_layers: int = param(0, "one_pass: layers per raster pass (0 = all in one)", lo=0)
    raster_size: int = param(0, "one_pass: samples per side of the swizzled raster (0 = the larger layer side)",
                             lo=0)
    splat_max: float = param(16.0, "splat: longest edge (texels) splatted; longer triangles go to splat_large",
                             lo=1e-6, hi=float(SPLAT_MAX_LIMIT))
    splat_batch: int = param(8, "splat: layers per compute invocation", lo=1, hi=65535)
    splat_group: int = param(64, "splat: invocations per workgroup", choices=(32, 64, 128, 256))
    splat_queue: bool = param(False, "splat: the (triangle, layer) pairs that reach a texel centre queued in "
                              "shared memory and rasterized by consecutive invocations (the same fragments)")
    splat_sort: bool = param(False, "splat, linked lists with yang2010's insert (sorted_insert = False) and the "
                             "long triangles by tiles: the tiles' pass sorts the lists it owns (up to 10 nodes, in "
                             "registers) and leaves only the longer ones to the sort pass (the same lists)")
    splat_large: str = param("tiles", "splat: the triangles longer than splat_max, by the hardware raster or "
                             "by a compute pass over tiles of the layers (the same fragments)", choices=SPLAT_LARGE)
    max_layers: int = param(1024, "peel: depth-peeling passes at most (reaching it with fragments left marks "
                            "the row degraded)", lo=1, hi=1 << 20)
    canonical: bool = param(False, "linear: order fragments at equal depth by their payload words (stage canon)")
    page_nodes: int = param(0, "linked: nodes per SSBO page, a power of two (0 = from the SSBO size limit)",
                            lo=0, hi=1 << 30)

    def __post_init__(self):
        object.__setattr__(self, "payload", tuple(self.payload))
        super().__post_init__()
        p = self.payload
        if any(w not in PAYLOAD_WORDS for w in p) or len(set(p)) != len(p):
            raise LdbenchError(f"parameter structure.payload={p!r}: words must be distinct names from "
                               f"{list(PAYLOAD_WORDS)}")
        if self.assembly == "sort" and self.layout != "linear":
            raise LdbenchError("parameter structure.assembly='sort' needs structure.layout='linear'")
        if self.pool == "count" and self.layout != "linked":
            raise LdbenchError("parameter structure.pool='count' needs structure.layout='linked' "
                               "(linear arrays always count)")
        if self.pool == "fixed" and self.pool_capacity < 1:
            raise LdbenchError("parameter structure.pool='fixed' needs structure.pool_capacity >= 1")
        if self.page_nodes & (self.page_nodes - 1):
            raise LdbenchError(f"parameter structure.page_nodes={self.page_nodes} must be a power of two (or 0)")
        if self.canonical and self.layout != "linear":
            raise LdbenchError("parameter structure.canonical needs structure.layout='linear'")
        if self.source == "peel" and (self.layout, self.assembly, self.pool) != ("linear", "direct", "grow"):
            raise LdbenchError("parameter structure.source='peel' builds compacted layers: it needs "
                               "structure.layout='linear', assembly='direct' and pool='grow'")
