"""Where cdi-vpl's indirect light goes on a spot-lit coloured wall beside a floor (docs/reference/methods/cdi_vpl.md,
"Energy budget"): the method's mean radiance over the image and over the floor against Mitsuba's one-bounce
reference, with each factor switched off or to its exact variant, one at a time.

    python scripts/cdi_vpl_energy.py [--size 48] [--spp 256] [--rsm 64]
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from testkit import wall_floor_scene  # noqa: E402

from ldbench.core.effects import Effect  # noqa: E402
from ldbench.core.gpu import Gpu  # noqa: E402
from ldbench.methods.base import View  # noqa: E402
from ldbench.methods.cdi_vpl import CdiVpl, CdiVplParams  # noqa: E402
from ldbench.references import render_reference, trace  # noqa: E402

UNCUT = {"vpl.range": "random", "vpl.r_min": 10.0, "vpl.r_max": 10.0}  # every VPL reaches every point
VARIANTS = (
    ("default (CDI ranges, mean, miss 0.5 diag)", {}),
    ("exact ranges (Mitsuba, same rays)", {"vpl.range": "exact"}),
    ("range_mode = max", {"indirect.range_mode": "max"}),
    ("miss_range = 2 diag", {"indirect.miss_range": 2.0}),
    ("ranges cut nowhere", UNCUT),
    ("cut nowhere, grid = 1", {**UNCUT, "indirect.grid": 1}),
    ("cut nowhere, no depth mask", {**UNCUT, "indirect.depth_mask": False}),
    ("cut nowhere, RSM x2 (every 2nd texel, flux x4)", {**UNCUT, "indirect.vpl_step": 2, "rsm_scale": 2}),
    ("cut nowhere, RSM x2, every texel", {**UNCUT, "rsm_scale": 2}),
)


def run(gpu, scene, size, **params):
    m = CdiVpl(CdiVplParams.from_dict(params))
    m.oracle = trace  # the exact baseline some modes ask for (what the runner hands every adapter)
    m.setup(gpu, scene)
    try:
        return m.frame(View(scene.camera, size, size), Effect("indirect")).resolve()
    finally:
        m.release()


def budget(gpu, scene, ref, size, rsm, variants=VARIANTS):
    """{label: (image ratio, floor ratio, per-channel floor ratio)} of mean radiance, method / reference."""
    spec = Effect("indirect").spec
    out = {}
    for label, kw in variants:
        kw = dict(kw)
        R = rsm * kw.pop("rsm_scale", 1)
        r = run(gpu, scene, size, **{"indirect.rsm": R, "indirect.vpl_step": kw.pop("indirect.vpl_step", 1), **kw})
        img, _ = spec.method_image(r, ref)
        m = ref.mask
        floor = m & floor_mask(scene, size)
        out[label] = (img[m].mean() / ref.mean[m].mean(), img[floor].mean() / ref.mean[floor].mean(),
                      img[floor].mean(0) / ref.mean[floor].mean(0))
    return out


def floor_mask(scene, size) -> np.ndarray:
    """Pixels whose primary ray hits the floor (y = 0) before the wall (x = −2), inside the floor."""
    o, d = scene.camera.primary_rays(size, size)
    o = np.broadcast_to(o, d.shape)
    t = -o[:, 1] / np.where(np.abs(d[:, 1]) > 1e-9, d[:, 1], -1e-9)
    p = o + t[:, None] * d
    ok = (t > 0) & (np.abs(p[:, 0]) <= 2) & (np.abs(p[:, 2]) <= 2)
    return ok.reshape(size, size)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=48)
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--rsm", type=int, default=64)
    a = ap.parse_args()
    scene = wall_floor_scene()
    ref = render_reference(scene, Effect("indirect"), width=a.size, height=a.size, spp=a.spp, progress=False)
    gpu = Gpu()
    for label, (im, fl, ch) in budget(gpu, scene, ref, a.size, a.rsm).items():
        print(f"{label:<50} image {100 * (im - 1):+6.1f} %  floor {100 * (fl - 1):+6.1f} %  floor RGB "
              + " ".join(f"{100 * (c - 1):+6.1f}" for c in ch))


if __name__ == "__main__":
    main()
