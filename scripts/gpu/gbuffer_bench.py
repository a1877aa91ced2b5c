"""G-buffer timing (docs/reference/methods/gbuffer.md): the hardware pass and the compute G-buffer (ldbench/methods/gbuffer.py) on
atrium at 260,000 triangles and 800 × 800, each the median of 20 frames by GL timer query (wall clock
around glFinish on llvmpipe), with the compute G-buffer's per-pass split and, untimed, how far its
textures are from the hardware's on this GPU; where the GPU has 64-bit atomics, the compute G-buffer both in
its one 64-bit pass (the default there) and in two 32-bit passes.

    python scripts/gpu/gbuffer_bench.py [--dry] [--max-pixels 64,256,1024] [--frames 20] [--size 800|3840x2160]

--dry: a small atrium at 64 × 64 and 3 frames (llvmpipe); --max-pixels: the compute raster's large-triangle
thresholds to measure (GBuffer's max_pixels; default: its default).
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from ldbench.core.gpu import Gpu
from ldbench.core.scenes import load_scene
from ldbench.methods.base import View
from ldbench.methods.gbuffer import VIS64_EXTENSIONS, GBuffer, SceneGeometry, mat_bytes


def timed(gpu, fn) -> float:
    """ms of ``fn()`` on the GPU: one timer query, or wall clock around glFinish without them."""
    if gpu.timer_queries:
        q = gpu.ctx.query(time=True)
        with q:
            fn()
        ms = q.elapsed * 1e-6
        if hasattr(q, "release"):  # moderngl < 5.8 has no Query.release
            q.release()
        return ms
    gpu.ctx.finish()
    t0 = time.perf_counter()
    fn()
    gpu.ctx.finish()
    return (time.perf_counter() - t0) * 1e3


def passes(g: GBuffer, view, vp):
    """The compute G-buffer's passes in render's order, as (name, callable)."""
    out = [("clear", g.clear)]
    for p in g.passes:
        out += [(f"compute{p}", lambda p=p: g.compute_pass(p, vp))]
        out += [("clip", lambda: g.clip_pass(vp)), ("expand", lambda: g.expand_pass(vp))] if p == 0 else []
        out += [(f"wide{p}", lambda p=p: g.wide_pass(p, vp)), (f"hardware{p}", lambda p=p: g.large_pass(p, vp))]
    return out + [("resolve", lambda: g.resolve(view, vp))]


def differences(ref, out, eye, vp) -> str:
    """How far the compute G-buffer's textures are from the hardware's (``out`` and ``ref`` as
    GBuffer.read): coverage, pixels showing another triangle (normal or material), window-depth gaps in
    steps of 2^-24, position errors over the eye distance."""
    (hp, hn, _), (cp, cn, _) = ref, out
    hm, cm = hp[..., 3] > 0.5, cp[..., 3] > 0.5
    both = hm & cm

    def zwin(p):
        h = np.concatenate([p[:, :3].astype(np.float64), np.ones((len(p), 1))], 1) @ vp.T
        return h[:, 2] / h[:, 3] * 0.5 + 0.5

    gap = np.abs(zwin(hp[both]) - zwin(cp[both])) * 2.0 ** 24
    tri = np.any(hn[both] != cn[both], -1)
    err = np.abs(hp[both][:, :3] - cp[both][:, :3]).max(1) / np.linalg.norm(hp[both][:, :3] - eye, axis=1)
    q = (lambda a: f"max {a.max():.3g}, 99.9% {np.percentile(a, 99.9):.3g}") if both.any() else (lambda a: "-")
    return (f"covered {int(hm.sum())}: {int((hm != cm).sum())} by one raster only, {int(tri.sum())} another "
            f"triangle (their depth gap max {gap[tri].max() if tri.any() else 0:.3g} steps); depth gap {q(gap)} "
            f"steps of 2^-24; position error over distance {q(err)}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--dry", action="store_true")
    ap.add_argument("--max-pixels", default="")
    ap.add_argument("--frames", type=int, default=20)
    ap.add_argument("--size", default="800", help="N (square) or WxH (default 800)")
    a = ap.parse_args(argv)
    w, _, h = a.size.partition("x")
    spec, (width, height), frames = (("atrium:triangles=4000", (64, 64), 3) if a.dry else
                                     ("atrium:triangles=260000", (int(w), int(h or w)), a.frames))
    gpu = Gpu()
    scene = load_scene(spec)
    res = gpu.resources()
    geo = SceneGeometry(gpu, scene, res)
    view = View(scene.camera, width, height)
    print(f"{gpu.info.get('GL_RENDERER')}: {spec}, {geo.triangles} triangles, {width} x {height}, median of {frames}")
    hw = GBuffer(gpu, geo, gpu.resources("hw."))
    hw.render(view)
    t = [timed(gpu, lambda: hw.render(view)) for _ in range(frames)]
    print(f"hardware  {np.median(t):8.3f} ms")
    ref = [x.copy() for x in hw.read()]
    forms = [(mp, v64) for mp in [int(x) for x in a.max_pixels.split(",") if x] or [None]
             for v64 in ((None, False) if VIS64_EXTENSIONS <= set(gpu.ctx.extensions) else (None,))]
    for mp, v64 in forms:
        kw = {} if mp is None else {"max_pixels": mp}
        g = GBuffer(gpu, geo, gpu.resources(f"c{mp}.{v64}."), raster="compute", vis64=v64, **kw)
        g.render(view)
        t = [timed(gpu, lambda: g.render(view)) for _ in range(frames)]
        vp = mat_bytes(g.view_proj(view))
        split = {}
        for _ in range(frames):
            for name, fn in passes(g, view, vp):
                split.setdefault(name, []).append(timed(gpu, fn))
        wide, tiles = g.wide_triangles()
        print(f"compute   {np.median(t):8.3f} ms  ({'one 64-bit pass' if g.vis64 else 'two 32-bit passes'}, "
              f"max_pixels {g.max_pixels}: {wide} triangles and polygons in {tiles} "
              f"tiles ({g.skipped_tiles()} skipped), {g.clipped_polygons()} polygons of clipped triangles, {g.large_triangles()} to the hardware)  " + "  ".join(f"{k} {np.median(v):.3f}" for k, v in split.items()))
        print("          " + differences(ref, g.read(), np.array(scene.camera.origin), g.view_proj(view)))


if __name__ == "__main__":
    main()
