"""Dual depth peeling vs depth peeling by counting (no timing): passes, fragments each geometry pass
shades, blends and reads, and CPU sync points, on one scene and view. Written for docs/reference/methods/oit.md,
"Why dual depth peeling is not faster here".

    python scripts/ddp_counts.py [--scene hairball --set triangles=20000 --set opacity=0.3] [--size 512x512]

Per pixel with L fragments, dual peeling's pass k (1-based) has max(0, L − 2(k − 1)) fragments left in its
depth interval (ties aside); every other fragment of the pixel is peeled already. Bytes are per fragment:
render-target blending reads and writes the target (RG32F 8 B, RGBA32F 16 B), texelFetch reads.
"""
from __future__ import annotations

import argparse

import numpy as np

from ldbench.core.gpu import Gpu
from ldbench.core.scenes import load_scene
from ldbench.core.effects import Effect
from ldbench.methods.base import View, get_method


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--scene", default="hairball")
    ap.add_argument("--set", action="append", default=["triangles=20000", "opacity=0.3"])
    ap.add_argument("--size", default="512x512")
    a = ap.parse_args()
    kw = {k: float(v) if "." in v else int(v) for k, v in (s.split("=", 1) for s in a.set)}
    w, h = map(int, a.size.split("x"))
    scene = load_scene(a.scene, **kw)
    gpu = Gpu()
    out = {}
    for name in ("depth-peeling", "dual-depth-peeling"):
        cls = get_method(name)
        m = cls(cls.Params())
        m.setup(gpu, scene)
        try:
            r = m.frame(View(scene.camera, w, h), Effect("oit")).resolve()
            out[name] = r.counters
            if name == "dual-depth-peeling":
                from ldbench.methods.oit import camera_transform
                clip = camera_transform(m.geo, View(scene.camera, w, h))[0]
                L = m._fragment_counts(clip, w, h).astype(np.int64)
        finally:
            m.release()
    F = int(L.sum())
    dp, ddp = out["depth-peeling"], out["dual-depth-peeling"]
    P = ddp["peel_passes"]
    left = [int(np.maximum(0, L - 2 * k).sum()) for k in range(P)]  # fragments inside pass k+1's interval
    blend_old = 8 + 16 + 16  # RG32F + RGBA32F + RGBA32F, read-modify-write under MAX blending
    print(f"scene {a.scene} {kw} at {w}x{h}: {F} fragments, max depth {int(L.max())}, "
          f"{int((L > 0).sum())} pixels covered")
    print(f"depth peeling: {dp['peel_passes']} geometry passes, {dp['peel_passes']} composite passes, "
          f"{dp['peel_passes']} query read-backs; per pass every fragment reads 4 B (depth texture) and is "
          f"depth-tested, the passing ones write 16 B (RGBA32F) + depth, no blending")
    print(f"dual depth peeling: 1 + {P} geometry passes, {P} blend passes, {P} query read-backs, "
          f"3 + 3 × {P} clears (pass-through) or 3 + 2 × {P} + 1 clears and {P - 1} front copies (default)")
    print(f"  pass-through (original): {P * F} fragment shadings, each 24 B texel reads + 3 blended targets "
          f"({2 * blend_old} B read+write): {P * F * (24 + 2 * blend_old) / 2**20:.1f} MiB over the frame")
    kept = sum(left)
    print(f"  default (peeled discarded): {P * F} shadings, {P * F - kept} discarded after 8 B, {kept} blended "
          f"(24 + {2 * blend_old} B): {((P * F - kept) * 8 + kept * (24 + 2 * blend_old)) / 2**20:.1f} MiB, plus "
          f"{P - 1} front copies of {w * h * 16 / 2**20:.1f} MiB")
    print(f"  fragments inside the interval per pass: {left}")


if __name__ == "__main__":
    main()
