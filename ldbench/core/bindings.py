"""The one table of buffer and image bindings shared by the Python adapters and the GLSL kernels.

Each entry ``NAME`` is one binding point: Python binds with ``buffer.bind_to_storage_buffer(B.NAME)``,
GLSL declares ``layout(std430, binding = B_NAME)``; the shader loader (:func:`ldbench.core.gpu.shader_source`)
puts :func:`glsl_header` (``#define B_NAME n`` for every entry) into every shader, so no number is
written twice.

Numbers are reused on purpose (the traces' buffers stay at or below 21, the highest binding the kernels
used when this table was made): an entry's ``scope`` says which family of programs it belongs to. Numbers
are unique within a scope; scopes that share a number never meet in one program, which
:func:`program_mismatches` checks for every program the harness compiles (two blocks on one binding),
together with each block's binding against this table (by its GLSL block name, ``glsl``).

Texture units of ``sampler2D`` uniforms are set from Python on both sides (the uniform's value and
``texture.use(unit)``) and are not in this table.
"""
from __future__ import annotations

from dataclasses import dataclass
from types import MappingProxyType

KINDS = ("ssbo", "ubo", "texture", "image")


@dataclass(frozen=True)
class Binding:
    """One binding point: ``kind``, its ``number``, the program family (``scope``) where that number
    means this buffer, what it holds, and the GLSL names declared at it (block names for ssbo/ubo,
    uniform names for texture/image)."""
    kind: str
    number: int
    scope: str
    meaning: str
    glsl: tuple


def _b(kind, number, scope, meaning, *glsl):
    return Binding(kind, number, scope, meaning, tuple(glsl))


_TABLE = {
    # -- rasters of the scene (ldbench/methods/gbuffer.py, ldbench/methods/cdi_vpl/rsm.glsl)
    "ALBEDO": _b("ssbo", 0, "raster", "albedo of each material (mesh), read by the G-buffer and RSM rasters",
                 "Albedo"),
    "GBUF_VERTICES": _b("ssbo", 1, "raster", "vertices (position, normal, material) read by the compute G-buffer",
                        "GbufVertices"),
    "GBUF_VIS": _b("ssbo", 2, "raster", "compute G-buffer: per-pixel depth keys, then per-pixel triangle ids",
                   "GbufVis"),
    "GBUF_LARGE": _b("ssbo", 3, "raster", "compute G-buffer: indirect command and triangles left to the hardware",
                     "GbufLarge"),
    "GBUF_WIDE": _b("ssbo", 4, "raster", "compute G-buffer: wide triangles, their tile counts and dispatches",
                    "GbufWide"),
    "GBUF_TILES": _b("ssbo", 5, "raster", "compute G-buffer: the wide triangles' tiles", "GbufTiles"),
    "GBUF_CLIP": _b("ssbo", 6, "raster", "compute G-buffer: the clipped triangles' polygons, set up for the "
                    "tile raster", "GbufClip"),
    "GBUF_CLIP_LIST": _b("ssbo", 7, "raster", "compute G-buffer: the triangles to clip and their dispatch",
                         "GbufClipList"),
    # -- one-kernel utilities, each alone in its program
    "FILL": _b("ssbo", 0, "fill_uint", "the uint buffer common/fill_uint.glsl clears", "FillData"),
    "SCAN_DATA": _b("ssbo", 0, "scan", "values scanned in place (ldbench/methods/scan.py)", "ScanData"),
    "SCAN_SUMS": _b("ssbo", 1, "scan", "per-workgroup sums of the scan", "ScanSums"),
    "PROBE": _b("ssbo", 0, "splat_probe", "the raster-rule probe's per-texel records", "Probe"),
    # -- the layered structures (ldbench/methods/structures/: core.py, linked.py, linear.py) and their sources
    "COUNTERS": _b("ssbo", 0, "structure", "the structure's counters (LL_C_* / LA_C_* indices)",
                   "LLCounters", "LACounters"),
    "HEADS": _b("ssbo", 1, "structure", "per-pixel list heads (linked list) or offsets (linear arrays)",
                "LLHeads", "LAOffsets"),
    "LAYERS": _b("ssbo", 2, "structure", "per-layer raster transforms (set_layers)", "LSLayers"),
    "NODES0": _b("ssbo", 3, "structure", "node page 0 (linked list) or the depth array (linear arrays)",
                 "LLNodes0", "LADepth"),
    "NODES1": _b("ssbo", 4, "linked_list", "linked-list node page 1", "LLNodes1"),
    "NODES2": _b("ssbo", 5, "linked_list", "linked-list node page 2", "LLNodes2"),
    "NODES3": _b("ssbo", 6, "linked_list", "linked-list node page 3", "LLNodes3"),
    "PAIRS": _b("ssbo", 4, "linear_arrays", "(depth, payload) pairs of the sorted linear-array build; node "
                "page 1's number, which linear arrays do not have", "LSPairs"),
    "PAYLOAD": _b("ssbo", 7, "structure", "per-fragment payload (LS_PAYLOAD > 0)", "LLPayload", "LAPayload"),
    "SPLAT_VERTICES": _b("ssbo", 8, "structure", "vertices (position, normal, material) of the splat build",
                         "SplatVertices"),
    "LS_ALBEDO": _b("ssbo", 9, "structure", "albedo of each material, stored as payload (RGBA8) by builds and "
                    "peels; read by material id by the LDI gather", "LSAlbedo"),
    "SPLAT_LARGE": _b("ssbo", 10, "structure", "splat build: indirect command and triangles too large to splat",
                      "SplatLarge"),
    "SPLAT_SORT": _b("ssbo", 12, "structure.splat", "splat build, tiles sorting their lists: the lists left to the "
                     "sort pass (count, then list indices)", "SplatSortLists"),
    "SPLAT_BOXES": _b("ssbo", 13, "structure.splat", "splat build, tiles: the long triangles' texel boxes in every "
                      "layer", "SplatBoxes"),
    "SPLAT_SETUPS": _b("ssbo", 14, "structure.splat", "splat build, tiles: the long triangles' edges, biases and "
                       "planes in every layer, set up by the boxes pass", "SplatSetups"),
    "SPLAT_POSITIONS": _b("ssbo", 15, "structure.splat", "splat build: each triangle's three positions (vec4), "
                          "SceneGeometry.triangle_positions", "SplatPositions"),
    "ORTHO_AXES": _b("ssbo", 11, "trace", "axes of the orthographic layer sets the traces walk (ortho_layers)",
                     "OrthoAxes"),
    "OIT_MATERIALS": _b("ssbo", 11, "oit", "albedo and opacity of each material (oit/oit.glsl)", "OITMaterials"),
    # -- per-method buffers of the traces, 12..19
    "LDM_ANGLE": _b("ssbo", 12, "ldm", "statistics: angle between each ray and its map's direction",
                    "LdmAngle"),
    "LDM_LUT": _b("ssbo", 13, "ldm", "direction -> map lookup table of the LDM traces", "LdmLut"),
    "LDM_AO_SUMS": _b("ssbo", 14, "ldm.ao", "AO over batches of maps: each pixel's running sums", "LdmAoSums"),
    "PHOTONS": _b("ssbo", 14, "ldm.photons", "stored photons (photon.glsl, 64 bytes each)", "Photons"),
    "PHOTON_COUNT": _b("ssbo", 15, "ldm.photons", "photons stored (one atomic counter)", "PhotonCount"),
    "PHOTON_ACCUM": _b("ssbo", 16, "ldm.photons", "splatted radiance, 3 floats per pixel", "Accum"),
    "PHOTON_STATS": _b("ssbo", 17, "ldm.photons", "statistics: counts and power per photon or splat fate",
                       "PhotonStats", "SplatStats"),
    "CDI_LUT": _b("ssbo", 12, "cdi", "direction -> map lookup table of the CDI traces", "CdiLut"),
    "VPL_RANGES": _b("ssbo", 13, "cdi", "traced range of each VPL ray (vpl_range effect)", "VplRangeOut"),
    "VPLS": _b("ssbo", 14, "cdi", "the VPLs built from the RSM", "Vpls"),
    "GRID_OFF": _b("ssbo", 15, "cdi", "VPL grid: offsets of the cells", "GridOff"),
    "GRID_IDX": _b("ssbo", 16, "cdi", "VPL grid: VPL indices of the cells", "GridIdx"),
    "GRID_MASK": _b("ssbo", 17, "cdi", "VPL grid: visibility masks", "GridMask"),
    "VPL_TABLE": _b("ssbo", 18, "cdi", "table of the VPL build", "VplTable"),
    "GRID_OVERFLOW": _b("ssbo", 19, "cdi", "VPL grid: cells that overflowed", "GridOverflow"),
    "LDI_STATS": _b("ssbo", 12, "ldi", "statistics: per ray (rays) or per pixel (gather) crossings and ends",
                    "LdiStats"),
    "PEEL_PREV": _b("ssbo", 12, "structure.peel", "peel source: the previous layer's fragment per pixel", "PeelPrev"),
    "PEEL_CAND": _b("ssbo", 13, "structure.peel", "peel source: this pass's candidate per pixel", "PeelCand"),
    "PEEL_COUNT": _b("ssbo", 14, "structure.peel", "peel source: layers found per pixel", "PeelCount"),
    "PEEL_LOC": _b("ssbo", 15, "structure.peel", "peel source: location of each committed fragment", "PeelLoc"),
    "PEEL_FRAG": _b("ssbo", 16, "structure.peel", "peel source: the committed fragments", "PeelFrag"),
    "PEEL_COUNTERS": _b("ssbo", 17, "structure.peel", "peel source: counters", "PeelCounters"),
    "PEEL_VERTICES": _b("ssbo", 18, "structure.peel", "vertices (position, normal, material) read by the compaction",
                        "Vertices"),
    "OIT_COUNTERS": _b("ssbo", 12, "ll_oit", "linked-list OIT resolve: counters", "OITCounters"),
    "MLAB_LAYERS": _b("ssbo", 12, "mlab", "MLAB k-buffer: (premultiplied colour, transmittance) per slot",
                      "MlabLayers"),
    "MLAB_KEYS": _b("ssbo", 13, "mlab", "MLAB k-buffer: (depth, material bits) per slot", "MlabKeys"),
    "MLAB_COUNTS": _b("ssbo", 14, "mlab", "MLAB: layers in use per pixel", "MlabCounts"),
    "MLAB_LOCKS": _b("ssbo", 15, "mlab", "MLAB spinlock: one lock word per pixel", "MlabLocks"),
    "MLAB_STATS": _b("ssbo", 16, "mlab", "MLAB: fragments, lost fragments, merges", "MlabStats"),
    # -- the harness's ray batches (ldbench/methods/glsl/common/rays.glsl), shared by every method's ray queries
    "RAYS": _b("ssbo", 20, "rays", "the ray batch (harness ray layout)", "RayBatch"),
    "HITS": _b("ssbo", 21, "rays", "hit distance of each ray", "RayHits"),
    # -- images
    "OUT_IMAGE": _b("image", 0, "image", "the image a compute pass writes", "out_image", "out_ao"),
    "GBUF_POSITION": _b("image", 0, "gbuffer", "compute G-buffer resolve: world position", "gb_position"),
    "GBUF_NORMAL": _b("image", 1, "gbuffer", "compute G-buffer resolve: camera-facing normal, material",
                      "gb_normal"),
    "GBUF_ALBEDO": _b("image", 2, "gbuffer", "compute G-buffer resolve: albedo", "gb_albedo"),
    **{f"GTAO_DEPTH{i}": _b("image", i, "gtao.prefilter", f"GTAO's depth pre-filter: view-space depth, MIP level {i}",
                            f"out_depth{i}") for i in range(5)},
    # -- HBAO's deinterleaved access (ldbench/methods/hbao/layers.glsl): written by its deinterleave, read by the AO pass
    "HBAO_LAYERS": _b("ssbo", 0, "hbao", "HBAO's view-space positions and normals in 4x4 quarter-resolution layers",
                      "HbaoLayers"),
}

#: name -> :class:`Binding`, read-only.
TABLE = MappingProxyType(_TABLE)


class _Numbers:
    """``B.NAME`` -> the binding number of table entry ``NAME`` (read-only)."""
    __slots__ = ()

    def __getattr__(self, name):
        try:
            return _TABLE[name].number
        except KeyError:
            raise AttributeError(f"no binding {name!r} in ldbench/core/bindings.py") from None

    def __setattr__(self, name, value):
        raise AttributeError("binding numbers are set in the table of ldbench/core/bindings.py")

    def __dir__(self):
        return list(_TABLE)


B = _Numbers()


def _by_glsl() -> dict:
    out = {}
    for name, b in _TABLE.items():
        for g in b.glsl:
            out[(b.kind, g)] = name
    return out


def table_errors() -> list[str]:
    """What is wrong with the table itself: unknown kinds, negative numbers, one GLSL name under two
    entries, or two entries of one kind and scope on one number."""
    errs: list[str] = []
    seen: dict[tuple[str, str, int], str] = {}  # (kind, scope, number) -> entry name
    glsl: dict[tuple[str, str], str] = {}  # (kind, GLSL name) -> entry name
    for name, b in _TABLE.items():
        if b.kind not in KINDS:
            errs.append(f"{name}: kind {b.kind!r} is not one of {KINDS}")
        if not isinstance(b.number, int) or b.number < 0:
            errs.append(f"{name}: number {b.number!r} is not a binding")
        if not b.glsl:
            errs.append(f"{name}: no GLSL name")
        other = seen.setdefault((b.kind, b.scope, b.number), name)
        if other != name:
            errs.append(f"{name} and {other}: both {b.kind} {b.number} in scope {b.scope!r}")
        for g in b.glsl:
            other = glsl.setdefault((b.kind, g), name)
            if other != name:
                errs.append(f"GLSL {b.kind} {g!r} is under both {other} and {name}")
    return errs


def glsl_header() -> str:
    """``#define B_NAME number`` for every entry, one per line: the GLSL twin of :data:`B`."""
    return "\n".join(f"#define B_{name} {b.number}" for name, b in _TABLE.items())


def program_mismatches(program, *, strict: bool = True) -> list[str]:
    """Disagreements between a compiled moderngl program (or compute shader) and the table.

    Every storage block must sit at its table entry's number, every image uniform named in the table at its
    unit, and no two storage blocks may share a binding. ``strict``: a storage block the table does not
    name is a mismatch too (the project's own shaders); tests' scratch kernels pass ``strict=False``."""
    by_glsl = _by_glsl()
    errs: list[str] = []
    used: dict[int, str] = {}  # storage binding -> block name
    for member in program:
        m = program[member]
        kind = type(m).__name__
        if kind == "StorageBlock":
            name = by_glsl.get(("ssbo", m.name))
            if name is None:
                if strict:
                    errs.append(f"storage block {m.name} is not in the binding table (ldbench/core/bindings.py)")
            elif m.binding != _TABLE[name].number:
                errs.append(f"storage block {m.name} at binding {m.binding}, the table says B_{name} = "
                            f"{_TABLE[name].number}")
            other = used.setdefault(m.binding, m.name)
            if other != m.name:
                errs.append(f"storage blocks {other} and {m.name} share binding {m.binding}")
        elif kind == "Uniform" and ("image", m.name) in by_glsl:
            name = by_glsl[("image", m.name)]
            if m.value != _TABLE[name].number:
                errs.append(f"image {m.name} at unit {m.value}, the table says B_{name} = {_TABLE[name].number}")
    return errs
