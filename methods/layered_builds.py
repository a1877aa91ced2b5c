"""Fast builds of the layered structures: the compute splat, the sort assembly and the hardware fill rule.

Variants of the one build stage of :mod:`methods.layered` (docs/fast_builds.md). The hardware raster of
every triangle in every layer is the reference build; it is bound by the rasterizer's triangle rate, not
by memory (measured in docs/fast_builds.md).

``build = "splat"`` (:class:`Splat`)
    A compute-shader rasterizer for small triangles (``methods/glsl/splat_raster.glsl``): one invocation
    per (triangle, batch of ``splat_batch`` layers) projects the triangle into each layer of its batch,
    snaps it to the hardware's sub-pixel grid and stores every texel centre it covers with the same
    ``ls_store`` as the raster (every layout and pass works unchanged). Coverage follows the hardware's
    fill rule exactly: integer edge functions on ``GL_SUBPIXEL_BITS`` fixed point, samples at texel
    centres, ties on an edge resolved by the edge classes this GPU includes, and depth on the plane
    through the snapped or the given vertices as this GPU interpolates, measured once per context by
    :func:`fill_rule`. A triangle whose longest edge exceeds ``splat_max`` texels in some
    layer is appended by the splat to an index list that one instanced indirect draw gives to the
    hardware in the same pass. Layers must be affine (orthographic maps: LDM, CDI).

``assembly = "sort"`` (:func:`build_sorted`, linear layout)
    One fragment pass (any build) appends every fragment as a pair (list id, depth, payload words) and
    counts it in its list; an exclusive scan of the counts (:class:`methods.scan.Scan`), a scatter of the
    pairs into their lists (a counting sort by list id, ``methods/glsl/pairs_scatter.glsl``) and the
    per-list depth sort give the same contiguous sorted lists as the count → scan → fill → sort build
    with one fragment pass instead of two, and no compare-and-swap anywhere. Stages ``emit``, ``scan``,
    ``fill``, ``sort``.

The pool policy ``lazy`` of both layouts (no read-back inside a build) is in the layouts' modules.
"""
from __future__ import annotations

import numpy as np

from harness.bindings import B
from harness.errors import LdbenchError
from harness.gpu import GLSL_DIR

from .gbuffer import VERTEX_ATTRS
from .layered import fill_uint

SPLAT_MAX_LIMIT = 64       # texels: keeps the splat's integer edge functions within int32
B_VERTICES, B_LARGE = B.SPLAT_VERTICES, B.SPLAT_LARGE
CMD_WORDS = 8              # DrawElementsIndirectCommand (5 words) padded; the indices follow it
_RULES: dict = {}          # id(ctx) -> fill rule


#: the interpolation probe: window positions (texels of a 4 × 4 target) a fraction of a sub-pixel step off
#: the grid, and a steep varying (~100 per texel: the snapped and given planes differ by ~0.2)
_IPROBE_POS = np.array([(0.1 + 0.45 / 256, 0.2 - 0.43 / 256), (3.9 - 0.38 / 256, 0.6 + 0.47 / 256),
                        (1.3 + 0.49 / 256, 3.8 - 0.44 / 256)])
_IPROBE_VAL = np.array([0.0, 300.0, -200.0])


def fill_rule(gpu) -> dict:
    """The hardware's raster rules on this context, measured once: ``{"top", "bottom", "left", "right":
    bool (a texel centre exactly on such an edge is covered), "subpixel_bits": int, "snapped_plane": bool
    (varyings are interpolated on the plane through the snapped vertices, not the given ones)}``.

    Fill rule: two counter-clockwise right triangles sharing their diagonal, with edges through texel
    centres, and the same two clockwise, are rasterized into a 4 × 4 framebuffer (``splat_probe.glsl``).
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
    prog = gpu.program(GLSL_DIR / "splat_probe.glsl")
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


def layer_scale(clip: np.ndarray, width: int, height: int) -> tuple[float, bool]:
    """(the most texels per world unit of any layer, whether every layer is affine (w = 1))."""
    clip = np.asarray(clip, np.float64)
    s = np.maximum(np.linalg.norm(clip[:, 0, :3], axis=1) * width / 2,
                   np.linalg.norm(clip[:, 1, :3], axis=1) * height / 2)
    affine = bool(np.all(clip[:, 3, :3] == 0) and np.all(clip[:, 3, 3] == 1))
    return float(s.max()), affine


class Splat:
    """The ``splat`` build of one structure: the compute pass and the hardware draw of large triangles.

    Parameters: ``splat_max`` (texels, 1 … 64): longest edge rasterized in the compute pass;
    ``batch``: layers per invocation."""

    def __init__(self, structure, splat_max: float = 16.0, batch: int = 8):
        if not 0 < float(splat_max) <= SPLAT_MAX_LIMIT:
            raise LdbenchError(f"splat_max must be in (0, {SPLAT_MAX_LIMIT}] texels, got {splat_max}")
        if int(batch) < 1:
            raise LdbenchError(f"splat_batch must be >= 1, got {batch}")
        self.s, self.splat_max, self.batch = structure, float(splat_max), int(batch)
        self.rule = fill_rule(structure.gpu)
        n = structure.geo.triangles
        self.large = structure.res.buffer(structure.prefix + "splat.large", reserve=4 * (CMD_WORDS + 3 * n))
        cmd = np.zeros(CMD_WORDS, np.uint32)
        cmd[1], cmd[2] = structure.layers, CMD_WORDS  # instances = layers; the indices follow the command
        self.large.write(cmd.tobytes())
        self._vaos: dict = {}

    def defines(self, extra: dict) -> dict:
        r = self.rule
        return {**self.s.defines(), **extra, "SPLAT_BATCH": self.batch, "LS_SUBPIXEL_BITS": r["subpixel_bits"],
                "SPLAT_TOP": int(r["top"]), "SPLAT_BOTTOM": int(r["bottom"]), "SPLAT_LEFT": int(r["left"]),
                "SPLAT_RIGHT": int(r["right"]), "SPLAT_SNAPPED_PLANE": int(r["snapped_plane"])}

    def _large_vao(self, prog):
        key = id(prog)
        if key not in self._vaos:
            used = [(a, k) for a, k in VERTEX_ATTRS if a in prog]
            fmt = " ".join(f"{k}f" if (a, k) in used else f"{4 * k}x" for a, k in VERTEX_ATTRS)
            self._vaos[key] = self.s.gpu.ctx.vertex_array(
                prog, [(self.s.geo.vbo, fmt, *[a for a, _ in used])], index_buffer=self.large,
                index_element_size=4)
        return self._vaos[key]

    def run(self, extra: dict, capacity: int):
        """One fragment pass: the compute splat of the small triangles, then the hardware raster of the
        large ones (both store through ``ls_store`` compiled with ``extra``)."""
        s, gpu = self.s, self.s.gpu
        ctx = gpu.ctx
        if not s.layers_affine:
            raise LdbenchError("build 'splat' needs affine layer transforms (orthographic maps)")
        fill_uint(gpu, self.large, 1, 0)  # the index count of the draw command
        cs = gpu.compute(GLSL_DIR / "splat_raster.glsl", self.defines(extra))
        for name, v in (("ls_size", (s.width, s.height)), ("ls_capacity", int(capacity)),
                        ("n_triangles", s.geo.triangles), ("n_layers", s.layers),
                        ("splat_scale", s.layer_scale), ("splat_max", self.splat_max)):
            if name in cs:
                cs[name].value = v
        s.bind()
        if "albedo" in s.payload:
            s.geo.albedo.bind_to_storage_buffer(B.LS_ALBEDO)
        s.geo.vbo.bind_to_storage_buffer(B_VERTICES)
        self.large.bind_to_storage_buffer(B_LARGE)
        groups = max(1, min(-(-s.geo.triangles // 64), 65535))
        cs.run(groups, -(-s.layers // self.batch))
        ctx.memory_barrier()
        prog = gpu.program(GLSL_DIR / "layered_build.glsl", {**s.defines(), **extra})
        for name, v in (("ls_size", (s.width, s.height)), ("ls_capacity", int(capacity)), ("layer_base", 0)):
            if name in prog:
                prog[name].value = v
        s.bind()
        if "albedo" in s.payload:
            s.geo.albedo.bind_to_storage_buffer(B.LS_ALBEDO)
        s.fbo.use()
        s.fbo.viewport = (0, 0, s.width, s.height)
        ctx.disable(ctx.DEPTH_TEST | ctx.CULL_FACE | ctx.BLEND)
        self._large_vao(prog).render_indirect(self.large, ctx.TRIANGLES, 1, 0)
        ctx.memory_barrier()

    def large_triangles(self) -> int:
        """Triangles the last pass gave to the hardware (a read-back)."""
        return int(np.frombuffer(self.s.gpu.read(self.large, 4), np.uint32)[0]) // 3

    def release(self):
        for v in self._vaos.values():
            v.release()
        self._vaos.clear()


# ---- sort assembly (linear layout) ------------------------------------------------------------------
def _aggregate(gpu) -> dict:
    ext = gpu.ctx.extensions
    return {"LL_AGGREGATE": 1} if "GL_ARB_shader_ballot" in ext and "GL_ARB_gpu_shader_int64" in ext else {}


def _emit(s):
    fill_uint(s.gpu, s.offsets, s.n_lists + 1, 0)
    s._reset_counters(s.capacity)
    s._raster({"LS_EMIT": 1, **_aggregate(s.gpu)}, s.capacity)


def emitted(s) -> int:
    """Fragments the last emit pass appended (stored or not; a read-back)."""
    from .linear_arrays import C_EMITTED

    return int(s._counters()[C_EMITTED])


def build_sorted(s, stage, sync_sizing: bool):
    """The sort assembly of :class:`~methods.linear_arrays.LinearisedArrays` ``s`` (module docstring).
    ``sync_sizing``: read the emitted count back and redo the emit when the pairs did not fit (``grow``)."""
    n = s.n_lists
    with stage("emit"):
        _emit(s)
        if sync_sizing:
            need = emitted(s)
            if need > s.capacity and s.capacity < s.max_capacity:
                s._allocate(need)
                _emit(s)
            elif need < s.capacity // 2:
                s._shrink_to = max(need, 1)  # the pairs are in use: shrink before the next build
    with stage("scan"):
        s.scan.run(s.offsets, n + 1)
    with stage("fill"):
        cs = s.gpu.compute(GLSL_DIR / "pairs_scatter.glsl", s.defines())
        s.bind()
        cs.run(max(1, min(-(-s.capacity // 256), 65535)))
        s.gpu.ctx.memory_barrier()
    with stage("sort"):
        s._sort()


def list_counts(s) -> np.ndarray:
    """Fragments per list (layer-major, OpenGL rows) of a linear structure, from its offsets (a read-back):
    comparing two builds' counts gives the fragments one misses and adds (the one-pass raster's loss)."""
    if s.layout != "linear":
        raise LdbenchError("list_counts needs the linear layout")
    off = np.frombuffer(s.gpu.read(s.offsets, 4 * s.n_lists), np.uint32).astype(np.int64)
    return np.diff(np.concatenate([[0], np.minimum(off, s.capacity)]))
