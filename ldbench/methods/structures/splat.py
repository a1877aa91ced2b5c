"""The ``splat`` source: a compute rasterizer of small triangles with the hardware's fill rule.

Variant of the fragment pass of :mod:`ldbench.methods.structures` (docs/reference/methods/fast_builds.md). The hardware raster of
every triangle in every layer is the reference source; it is bound by the rasterizer's triangle rate, not
by memory (measured in docs/reference/methods/fast_builds.md).

:class:`Splat` (``ldbench/methods/glsl/layered/splat_raster.glsl``): one invocation per (triangle, batch of
``splat_batch`` layers) loads its positions (``SceneGeometry.triangle_positions``), projects the triangle
into each layer of its batch, snaps it to the hardware's
sub-pixel grid and stores every texel centre it covers with the same ``ls_store`` as the raster (every
layout and pass works unchanged). Coverage follows the hardware's fill rule exactly: integer edge
functions on ``GL_SUBPIXEL_BITS`` fixed point, samples at texel centres, ties on an edge resolved by the
edge classes this GPU includes, and depth on the plane through the snapped or the given vertices as this
GPU interpolates, measured once per context by :func:`fill_rule`. A triangle whose longest edge exceeds
``splat_max`` texels in some layer is appended by the splat to an index list of long triangles, which the
spec's ``splat_large`` rasterizes in the same build:

- ``tiles`` (default, ``ldbench/methods/glsl/layered/splat_tiles.glsl``): a compute pass over tiles of 8 × 8 texels of every
  layer, one invocation per texel, which bins the long triangles meeting its tile and tests its centre with
  the same fill rule (edge functions exact at any size, stepped per texel in int32), after a pass that sets up
  the first ``BOX_CAP`` long triangles (box, edges, planes) in every layer (the tiles set up any others
  themselves); its stores: ``layered/splat_tiles.glsl``. Why it is the default: docs/reference/methods/fast_builds.md.
- ``raster``: one instanced indirect draw of them by the hardware (``layered/build.glsl``).

Layers must be affine (orthographic maps: LDM, CDI, LDI).
"""
from __future__ import annotations

import numpy as np

from ldbench.core.bindings import B
from ldbench.core.errors import LdbenchError
from ldbench.core.gpu import GLSL_DIR

from .core import fill_uint
from .sources import FragmentSource, Raster

B_VERTICES, B_LARGE, B_SORT = B.SPLAT_VERTICES, B.SPLAT_LARGE, B.SPLAT_SORT
B_BOXES, B_SETUPS, B_POSITIONS = B.SPLAT_BOXES, B.SPLAT_SETUPS, B.SPLAT_POSITIONS
TILE_X, TILE_Y = 8, 8      # texels per tile of the long triangles' pass (layered/splat_tiles.glsl)
TILE_LAYERS = 2            # layers a workgroup of that pass takes in turn
GROUP_CHUNKS = 4           # with the queue: chunks of splat_group triangles a splat workgroup takes in turn
WIN_ROWS = 256             # layers of a splat batch whose window rows the queue keeps in shared memory (8 KB)
BOX_CAP = 256              # long triangles whose boxes and set-ups in every layer the boxes pass writes (layered/splat_tiles.glsl)
CMD_STRIDE = 5             # words of a DrawElementsIndirectCommand (the draws' tight stride; layered/splat_raster.glsl's 5u)
CMD_WORDS = 16             # two of them (one per pass parity), padded; the indices follow
_RULES: dict = {}          # id(ctx) -> fill rule


#: the interpolation probe: window positions (texels of a 4 × 4 target) a fraction of a sub-pixel step off
#: the grid, and a steep varying (~100 per texel: the snapped and given planes differ by ~0.2)
_IPROBE_POS = np.array([(0.1 + 0.45 / 256, 0.2 - 0.43 / 256), (3.9 - 0.38 / 256, 0.6 + 0.47 / 256),
                        (1.3 + 0.49 / 256, 3.8 - 0.44 / 256)])
_IPROBE_VAL = np.array([0.0, 300.0, -200.0])


def rule_defines(rule: dict) -> dict:
    """The GLSL defines of a :func:`fill_rule` (``layered/splat_raster.glsl``, ``layered/fill_rule.glsl``)."""
    return {"LS_SUBPIXEL_BITS": rule["subpixel_bits"], "SPLAT_TOP": int(rule["top"]),
            "SPLAT_BOTTOM": int(rule["bottom"]), "SPLAT_LEFT": int(rule["left"]), "SPLAT_RIGHT": int(rule["right"]),
            "SPLAT_SNAPPED_PLANE": int(rule["snapped_plane"])}


def fill_rule(gpu) -> dict:
    """The hardware's raster rules on this context, measured once: ``{"top", "bottom", "left", "right":
    bool (a texel centre exactly on such an edge is covered), "subpixel_bits": int, "snapped_plane": bool
    (varyings are interpolated on the plane through the snapped vertices, not the given ones)}``.

    Fill rule: two counter-clockwise right triangles sharing their diagonal, with edges through texel
    centres, and the same two clockwise, are rasterized into a 4 × 4 framebuffer (``layered/splat_probe.glsl``).
    The rule must cover each shared edge exactly once (one of top/bottom, one of left/right) and not
    depend on the winding; anything else is refused. Interpolation: one triangle off the sub-pixel grid
    with a steep varying (:func:`plane_from_probe`). NVIDIA interpolates on the snapped plane, llvmpipe on
    the given one: the depths of a sliver differ by up to ~1 % between the two."""
    key = id(gpu.ctx)
    if key in _RULES:
        return _RULES[key]
    ctx = gpu.ctx
    # window coordinates; A: bottom edge y = 1.5, left edge x = 1.5, diagonal (its right edge) through
    # (2.5, 2.5); B: top edge y = 3.5, right edge x = 3.5, the diagonal as its left edge
    a = [(1.5, 1.5), (3.5, 1.5), (1.5, 3.5)]
    b = [(3.5, 3.5), (1.5, 3.5), (3.5, 1.5)]
    tris = [a, b, [a[0], a[2], a[1]], [b[0], b[2], b[1]]]  # CCW, CCW, CW, CW
    bits = int(ctx.info.get("GL_SUBPIXEL_BITS") or 8)
    prog = gpu.program(GLSL_DIR / "layered/splat_probe.glsl")
    fill = np.concatenate([np.array(tris, np.float32).reshape(-1, 2), np.zeros((12, 1), np.float32)], 1)
    interp = np.concatenate([_IPROBE_POS, _IPROBE_VAL[:, None]], 1).astype(np.float32)
    vbos = [ctx.buffer(fill.tobytes()), ctx.buffer(interp.tobytes())]
    out = ctx.buffer(reserve=4 * 16)
    fbo = ctx.empty_framebuffer((4, 4))
    found = []
    try:
        prog["probe_size"].value = (4.0, 4.0)
        prog["probe_width"].value = 4
        fbo.use()
        fbo.viewport = (0, 0, 4, 4)
        ctx.disable(ctx.DEPTH_TEST | ctx.CULL_FACE | ctx.BLEND)
        for mode, (vbo, blank) in enumerate(zip(vbos, (0, 0xFFFFFFFF))):
            vao = ctx.vertex_array(prog, [(vbo, "2f 1f", "in_position", "in_value")])
            prog["probe_mode"].value = mode
            fill_uint(gpu, out, 16, blank)
            out.bind_to_storage_buffer(B.PROBE)
            vao.render()
            ctx.memory_barrier()
            found.append(np.frombuffer(gpu.read(out), np.uint32).reshape(4, 4).copy())  # [y, x]
            vao.release()
    finally:
        for o in (*vbos, out, fbo):
            o.release()
    rule = rule_from_probe(found[0])
    rule["subpixel_bits"] = bits
    rule["snapped_plane"] = plane_from_probe(found[1].view(np.float32), bits)
    _RULES[key] = rule
    return rule


def plane_from_probe(values: np.ndarray, bits: int) -> bool:
    """Whether the probe triangle's interpolated values (4 × 4, NaN where not covered) lie on the plane
    through its vertices snapped to ``bits`` of sub-pixel precision (True) or through the given ones; the
    nearer of the two, refused when neither is near."""
    y, x = np.nonzero(np.isfinite(values))
    if len(x) < 3:
        raise LdbenchError("build 'splat': the interpolation probe covered too few texels")
    p = np.stack([x + 0.5, y + 0.5], 1)
    err = []
    for pos in (_IPROBE_POS, np.round(_IPROBE_POS * 2.0 ** bits) / 2.0 ** bits):
        m = np.c_[pos, np.ones(3)]
        coef = np.linalg.solve(m, _IPROBE_VAL)
        err.append(np.abs(np.c_[p, np.ones(len(p))] @ coef - values[y, x]).max())
    if min(err) > 0.02:
        raise LdbenchError(f"build 'splat': this GPU interpolates on neither the given nor the snapped "
                           f"plane (errors {err[0]:.3g}, {err[1]:.3g}); use build = 'raster'")
    return bool(err[1] < err[0])


def rule_from_probe(px: np.ndarray) -> dict:
    """The fill rule from the probe's 4 × 4 texels of primitive bits (:func:`fill_rule`); refused unless
    every shared edge is covered once and the winding does not matter."""
    def bits(t):  # t = 0: the counter-clockwise pair, 1: the clockwise pair
        a, b = 2 * t, 2 * t + 1
        return {"bottom": px[1, 2] >> a & 1, "left": px[2, 1] >> a & 1, "right": px[2, 2] >> a & 1,
                "top": px[3, 2] >> b & 1, "right_b": px[2, 3] >> b & 1, "left_b": px[2, 2] >> b & 1}
    ccw, cw = bits(0), bits(1)
    ok = (ccw == cw and ccw["top"] != ccw["bottom"] and ccw["left"] != ccw["right"]
          and ccw["left"] == ccw["left_b"] and ccw["right"] == ccw["right_b"])
    if not ok:
        raise LdbenchError(f"build 'splat': this GPU's fill rule is not a top/bottom-left/right rule "
                           f"(probe {np.asarray(px).tolist()}); use build = 'raster'")
    return {k: bool(ccw[k]) for k in ("top", "bottom", "left", "right")}


def boxes_fit(width: int, height: int) -> bool:
    """Whether the boxes pass's 16-bit texel indices hold a layer of ``width × height`` (else the tiles set up
    every long triangle themselves)."""
    return max(width, height) <= 1 << 16


def window_terms(clip: np.ndarray, width: int, height: int, extent: np.ndarray) -> float:
    """The largest sum of a window coordinate's terms over a scene within ``extent`` (the largest |coordinate|
    per axis), in texels: per layer and axis |row.xyz| · extent + |row.w| + the half size, the clip row scaled
    to the layer. The window coordinates' float rounding grows with it (vertices far from the origin)."""
    hs = np.array([width, height], np.float64) / 2
    r = np.abs(np.asarray(clip, np.float64)[:, :2, :]) * hs[None, :, None]
    return float(((r[:, :, :3] * np.asarray(extent, np.float64)).sum(2) + r[:, :, 3] + hs).max())


def tiles_narrow(longest_edge: float, scale: float, subpixel_bits: int, terms: float = 0.0) -> bool:
    """Whether no triangle can be wide in the tiles' pass (``layered/fill_rule.glsl`` ``fr_tile``: an edge component
    beyond its int32 steps' limit, in sub-pixel units): the longest edge in texels of the densest layer (``scale``),
    snapped, with room for the window coordinates' float rounding (2^-19 of their ``terms``,
    :func:`window_terms`), within the limit."""
    one = 1 << subpixel_bits
    lim = (1 << 30) // (one * (TILE_X + TILE_Y))
    return longest_edge * scale * one * 1.01 + 256 + terms * one * 2.0 ** -19 <= lim


def long_bound(longest_edges: np.ndarray, scale: float, splat_max: float) -> int:
    """The most triangles the splat can leave to the long triangles' pass (``layered/splat_raster.glsl`` ``sp_long``):
    those whose longest edge (world units) times ``scale`` exceeds ``splat_max``, with room for the GPU's float
    rounding, and those not finite."""
    x = np.asarray(longest_edges, np.float64) * scale
    return int(np.count_nonzero(~np.isfinite(x) | (x > splat_max * (1.0 - 1e-4))))


def setups_fit(layers: int, ssbo_limit: int) -> int:
    """The most long triangles whose set-ups (64 bytes per layer) fit one storage buffer of ``ssbo_limit``."""
    return ssbo_limit // (64 * layers)


class Splat(FragmentSource):
    """The ``splat`` source of one structure: the compute pass of the small triangles, then the long ones
    by the tiles' pass or the hardware draw (``splat_large``).

    The spec's ``splat_max`` (texels, ≤ 64): longest edge rasterized in the compute pass;
    ``splat_batch``: layers per invocation; ``splat_group``: invocations per workgroup."""

    def __init__(self, structure):
        super().__init__(structure)
        self.splat_max, self.batch = structure.spec.splat_max, structure.spec.splat_batch
        self.group, self.large_mode = structure.spec.splat_group, structure.spec.splat_large
        self.rule = fill_rule(structure.gpu)
        n = structure.geo.triangles
        self.large = structure.res.buffer(structure.prefix + "splat.large", reserve=4 * (CMD_WORDS + 3 * n))
        cmd = np.zeros(CMD_WORDS, np.uint32)
        for p in (0, 1):  # instances = layers; the indices follow the commands
            cmd[CMD_STRIDE * p + 1], cmd[CMD_STRIDE * p + 2] = structure.layers, CMD_WORDS
        self.large.write(cmd.tobytes())
        # passes alternate between the two commands: each splat counts its long triangles in its own and zeroes the
        # other for the next pass (whose readers, the tiles or the draw, have completed), so no pass clears a count
        self.parity = 1
        self._vaos: dict = {}
        spec = structure.spec
        self.tile_sort = (spec.splat_sort and self.large_mode == "tiles" and structure.layout == "linked"
                          and not spec.sorted_insert)
        self.sort_cap = structure.n_lists // 16 + 64   # lists the tiles may leave to the sort pass (then: all)
        self.sort_buf = (structure.res.buffer(structure.prefix + "splat.sort", reserve=4 * (1 + self.sort_cap))
                         if self.tile_sort else None)
        self._sorted_pass = False
        self._all_boxed = False   # the last tiles' pass took every long triangle from the boxes pass (SP_ALL_BOXED)
        self._long_bound = (None, 0)   # (layer scale, long_bound at it): one count over the triangles per scale
        self.box_cap = (min(n, BOX_CAP, setups_fit(structure.layers, structure.ssbo_limit))
                        if self.large_mode == "tiles" and boxes_fit(structure.width, structure.height) else 0)
        self.boxes = self.setups = None
        if self.box_cap:
            per_layer = self.box_cap * structure.layers
            self.boxes = structure.res.buffer(structure.prefix + "splat.boxes", reserve=8 * per_layer)
            self.setups = structure.res.buffer(structure.prefix + "splat.setups", reserve=64 * per_layer)

    def defines(self, extra: dict) -> dict:
        return {**self.s.defines(), **extra, "SPLAT_BATCH": self.batch, "SPLAT_GROUP": self.group,
                "SPLAT_WIN_N": min(self.batch, WIN_ROWS),
                "SPLAT_QUEUE": int(self.s.spec.splat_queue),
                **rule_defines(self.rule)}

    def _large_vao(self, prog):
        key = id(prog)
        if key not in self._vaos:
            self._vaos[key] = self.s.geo.vao(prog, index_buffer=self.large)
        return self._vaos[key]

    def run(self, extra: dict, capacity: int):
        """One fragment pass: the compute splat of the small triangles, then the large ones by the
        spec's ``splat_large``; every store is ``ls_store``'s compiled with ``extra`` (the tiles' own
        push for yang2010's insert: ``layered/splat_tiles.glsl``)."""
        s, gpu = self.s, self.s.gpu
        ctx = gpu.ctx
        if not s.layers_affine:
            raise LdbenchError("build 'splat' needs affine layer transforms (orthographic maps)")
        parity = self.parity ^ 1   # kept once the splat is dispatched: a pass that fails before leaves the counts as they were
        # the tiles sort the lists of the linked insert's pass (not of a counting pass)
        self._sorted_pass = self.tile_sort and "LS_PASS_COUNT" not in extra and "LL_SORTED" not in extra
        zero_sort = {"SP_ZERO_SORT": 1} if self._sorted_pass else {}   # the splat empties the tiles' list of lists
        cs = gpu.compute(GLSL_DIR / "layered/splat_raster.glsl", {**self.defines(extra), **zero_sort})
        self.uniforms(cs, capacity)
        cs["sp_parity"].value = parity
        if zero_sort:
            self.sort_buf.bind_to_storage_buffer(B_SORT)
        for name, v in (("n_triangles", s.geo.triangles), ("n_layers", s.layers),
                        ("splat_scale", s.layer_scale), ("splat_max", self.splat_max),
                        ("sp_extent", tuple(float(x) for x in s.geo.extent))):
            if name in cs:
                cs[name].value = v
        s.geo.vbo.bind_to_storage_buffer(B_VERTICES)
        s.geo.triangle_positions().bind_to_storage_buffer(B_POSITIONS)
        self.large.bind_to_storage_buffer(B_LARGE)
        chunks = GROUP_CHUNKS if s.spec.splat_queue else 1   # the queue's window rows: set up once per workgroup
        groups = max(1, min(-(-s.geo.triangles // (self.group * chunks)), 65535))
        cs.run(groups, -(-s.layers // self.batch))
        self.parity = parity
        ctx.memory_barrier()
        if self.large_mode == "tiles":
            self._tiles(extra, capacity)
        else:
            self._hardware(extra, capacity)

    def _tiles(self, extra: dict, capacity: int):
        """The long triangles by the compute pass over tiles (``layered/splat_tiles.glsl``), after the pass that sets them
        up in every layer."""
        s = self.s
        tiles = {**self.defines(extra), "SPLAT_TILE_X": TILE_X, "SPLAT_TILE_Y": TILE_Y, "SP_TILE_N": TILE_X * TILE_Y,
                 "SP_TILE_LAYERS": TILE_LAYERS}
        terms = window_terms(s.layer_clip, s.width, s.height, s.geo.extent)
        if tiles_narrow(s.geo.longest_edge, s.layer_scale, self.rule["subpixel_bits"], terms):
            tiles["FR_NARROW"] = 1
        if self._long_bound[0] != s.layer_scale:
            self._long_bound = (s.layer_scale, long_bound(s.geo.longest_edges, s.layer_scale, self.splat_max))
        self._all_boxed = bool(self.box_cap) and self._long_bound[1] <= self.box_cap
        if self._all_boxed:
            tiles["SP_ALL_BOXED"] = 1
        if self.boxes is not None:
            self.boxes.bind_to_storage_buffer(B_BOXES)
            self.setups.bind_to_storage_buffer(B_SETUPS)
            cs = s.gpu.compute(GLSL_DIR / "layered/splat_tiles.glsl", {**tiles, "SP_BOXES_PASS": 1})
            self.uniforms(cs, capacity)
            cs["sp_box_cap"].value = self.box_cap
            cs["sp_parity"].value = self.parity
            cs.run(s.layers)
            s.gpu.ctx.memory_barrier()
        sort = {"SP_TILE_SORT": 1} if self._sorted_pass else {}
        cs = s.gpu.compute(GLSL_DIR / "layered/splat_tiles.glsl", {**tiles, **sort})
        if sort:
            self.bind_sort(cs)
        self.uniforms(cs, capacity)
        cs["sp_box_cap"].value = self.box_cap
        cs["sp_parity"].value = self.parity
        cs["sp_layers"].value = s.layers
        cs.run(-(-s.width // TILE_X), -(-s.height // TILE_Y), -(-s.layers // TILE_LAYERS))
        s.gpu.ctx.memory_barrier()

    def _hardware(self, extra: dict, capacity: int):
        """The long triangles by one instanced indirect draw (``layered/build.glsl``)."""
        s, ctx = self.s, self.s.gpu.ctx
        prog = s.gpu.program(GLSL_DIR / Raster.shader, {**s.defines(), **extra})
        if "layer_base" in prog:
            prog["layer_base"].value = 0
        self.uniforms(prog, capacity)
        s.fbo.use()
        s.fbo.viewport = (0, 0, s.width, s.height)
        ctx.disable(ctx.DEPTH_TEST | ctx.CULL_FACE | ctx.BLEND)
        self._large_vao(prog).render_indirect(self.large, ctx.TRIANGLES, 1, self.parity)   # the pass's command
        ctx.memory_barrier()

    def bind_sort(self, prog):
        """The lists the tiles left unsorted, for the tiles' pass and the sort pass (``LL_SORT_LISTED``)."""
        prog["sp_sort_cap"].value = self.sort_cap
        self.sort_buf.bind_to_storage_buffer(B_SORT)

    def unsorted_lists(self):
        """``None`` when the last pass may have left any list unsorted; else this source, whose
        :meth:`bind_sort` binds the lists it left (the tiles sorted the others)."""
        return self if self._sorted_pass else None

    def stats(self) -> dict:
        out = {"splat_large_triangles": self.large_triangles()}
        if self._sorted_pass:  # lists longer than the tiles' registers, left to the sort pass
            out["splat_sort_left"] = int(np.frombuffer(self.s.gpu.read(self.sort_buf, 4), np.uint32)[0])
        return out

    def invariants(self, stats: dict) -> list[str]:
        """The tiles took every long triangle from the boxes pass (``SP_ALL_BOXED``) only while the host's bound
        held: more than the boxes pass's cap would have left the rest out."""
        n = stats.get("splat_large_triangles", 0)
        if self._all_boxed and n > self.box_cap:
            return [f"{n} long triangles, more than the {self.box_cap} set up by the boxes pass (long_bound exceeded)"]
        return []

    def large_triangles(self) -> int:
        """Long triangles the last pass left to the tiles or the hardware (a read-back)."""
        words = np.frombuffer(self.s.gpu.read(self.large, 4 * 2 * CMD_STRIDE), np.uint32)
        return int(words[CMD_STRIDE * self.parity]) // 3

    def release(self):
        for v in self._vaos.values():
            v.release()
        self._vaos.clear()
