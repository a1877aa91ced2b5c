"""How much the old secondary-ray origin biased the Mitsuba references: ``ao`` and ``indirect`` rendered with
the current origin (Mitsuba's spawn offset of the crease point, ldbench/core/conventions.py) and with the old
rule (x − 16 ε d_cam + ε n, reproduced here by patching the reference's primary hits), same seed, same
random numbers.

Per scene and effect, over all hit pixels ("image") and over the pixels near creases ("creases": within
2 pixels of a pixel whose normal differs by more than 30° and whose point is within 3 pixel footprints in
3D, i.e. a joint of two surfaces and not a silhouette):

- ``rel_mean``: (mean_new − mean_old) / mean_old of the region's mean value (all channels);
- ``rel_abs``: mean |new − old| / mean old, pixel by pixel;
- ``z``: (mean_new − mean_old) / σ, σ = the new reference's own standard error of the region's mean
  (√Σ variance / N): how many of its noise σ the change is.

Usage (from the project root; a CUDA variant on a GPU: ``LDBENCH_MITSUBA_VARIANT=cuda_ad_rgb``)::

    python scripts/reference_origin_bias.py --size 800 --spp 1024 --out /tmp/origin-bias     # full scale
    python scripts/reference_origin_bias.py --size 64 --spp 256                                # CPU, minutes

Scenes that cannot be loaded (``sponza`` not fetched: ``ldbench scenes fetch sponza``) are reported and
skipped. Writes ``origin_bias.csv``, ``origin_bias.md`` and ``origin_bias.png`` (per scene and effect, the
per-pixel (new − old) / old of the mean over channels, clipped to ±5 %) under ``--out`` (default: print only).
"""
from __future__ import annotations

import argparse
import csv
import math
import sys
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from ldbench.core.effects import Effect  # noqa: E402
from ldbench.core.errors import LdbenchError  # noqa: E402
from ldbench.core.scenes import load_scene  # noqa: E402
from ldbench.references import integrators as _int  # noqa: E402
from ldbench.references import primary_hits, render_reference  # noqa: E402


@contextmanager
def old_origin():
    """The references as before: the hit moved 16 ε(x) back along the camera ray, no crease point; the
    spawn offset ε n is then taken at that point, exactly as the old ``_offset`` did."""
    trace, spawn = _int.trace_primary, _int.spawn_points

    def trace_old(mi, dr, mscene, o, d):
        ray, si = trace(mi, dr, mscene, o, d)
        si.p = mi.Point3f(si.p) - mi.Vector3f(ray.d) * ((1.0 + dr.max(dr.abs(si.p))) * mi.math.RayEpsilon * 16)
        return ray, si

    _int.trace_primary = trace_old
    _int.spawn_points = lambda si: np.ascontiguousarray(_int.np3(si.p), np.float32)
    try:
        yield
    finally:
        _int.trace_primary, _int.spawn_points = trace, spawn


def crease_band(scene, size: int, radius: int = 2, angle: float = 30.0) -> np.ndarray:
    """(H, W) pixels near a joint of two surfaces (module docstring)."""
    hits = primary_hits(scene, size, size)
    m, n, x = hits["mask"], hits["normal"].astype(np.float64), hits["position"].astype(np.float64)
    dist = np.where(m, hits["distance"], np.inf)
    foot = dist * 2.0 * math.tan(math.radians(scene.camera.fov_y) / 2.0) / size
    band = np.zeros_like(m)
    cos = math.cos(math.radians(angle))
    for dy in range(-radius, radius + 1):
        for dx in range(-radius, radius + 1):
            if dx == dy == 0:
                continue
            ms, ns, xs = (np.roll(a, (dy, dx), axis=(0, 1)) for a in (m, n, x))
            near = np.linalg.norm(x - xs, axis=-1) < 3.0 * (abs(dx) + abs(dy)) * foot
            band |= m & ms & ((n * ns).sum(-1) < cos) & near
    return band


def compare(new, old, region) -> dict:
    mn, mo = new.mean[region].astype(np.float64), old.mean[region].astype(np.float64)
    N = int(region.sum())
    if N == 0:
        return {"pixels": 0, "rel_mean": math.nan, "rel_abs": math.nan, "z": math.nan}
    a, b = mn.mean(), mo.mean()
    sigma = math.sqrt(float(new.variance[region].astype(np.float64).sum())) / mn.size
    return {"pixels": N, "rel_mean": (a - b) / b if b else math.nan,
            "rel_abs": float(np.abs(mn - mo).mean()) / b if b else math.nan,
            "z": (a - b) / sigma if sigma > 0 else math.nan}


def save_maps(maps, path: Path, clip: float = 0.05):
    """One panel per (scene, effect): the per-pixel relative change, diverging colours, background grey."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cols = 2
    rows = (len(maps) + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 4.0 * rows), squeeze=False)
    cmap = plt.get_cmap("RdBu_r").copy()
    cmap.set_bad("0.85")
    for ax, (title, img) in zip(axes.flat, maps):
        im = ax.imshow(img, cmap=cmap, vmin=-clip, vmax=clip, interpolation="nearest")
        ax.set_title(title, fontsize=10)
        ax.set_axis_off()
    for ax in list(axes.flat)[len(maps):]:
        ax.set_axis_off()
    fig.colorbar(im, ax=axes.ravel().tolist(), shrink=0.6, label="(new − old) / old  (clipped to ±5 %)")
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", default="cornell,atrium,sponza")
    ap.add_argument("--effects", default="ao,indirect")
    ap.add_argument("--size", type=int, default=800)
    ap.add_argument("--spp", type=int, default=1024)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    rows, maps = [], []
    for name in args.scenes.split(","):
        try:
            scene = load_scene(name)
        except LdbenchError as e:
            print(f"{name}: skipped ({e})", file=sys.stderr)
            continue
        band = crease_band(scene, args.size)
        for eff in args.effects.split(","):
            effect = Effect(eff)
            kw = dict(width=args.size, height=args.size, spp=args.spp, seed=args.seed, cache=False, progress=False)
            t0 = time.perf_counter()
            new = render_reference(scene, effect, **kw)
            with old_origin():
                old = render_reference(scene, effect, **kw)
            secs = time.perf_counter() - t0
            m = new.mask & old.mask
            mo, mn = old.mean.astype(np.float64).mean(-1), new.mean.astype(np.float64).mean(-1)
            maps.append((f"{name} {eff}", np.where(m & (mo > 0), (mn - mo) / np.where(mo > 0, mo, 1), np.nan)))
            for region, sel in (("image", m), ("creases", m & band)):
                r = {"scene": name, "effect": eff, "region": region, **compare(new, old, sel),
                     "size": args.size, "spp": args.spp, "variant": new.meta["variant"], "seconds": round(secs, 1)}
                rows.append(r)
                print(f"{name:8s} {eff:8s} {region:8s} pixels {r['pixels']:7d}  rel_mean {r['rel_mean']:+.4%}  "
                      f"rel_abs {r['rel_abs']:.4%}  z {r['z']:+.1f}  ({secs:.0f} s)", flush=True)
    if args.out and rows:
        args.out.mkdir(parents=True, exist_ok=True)
        with open(args.out / "origin_bias.csv", "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
        lines = ["| scene | effect | region | pixels | (new − old) / old, mean | mean \\|new − old\\| / old | "
                 "in σ of the reference |", "|---|---|---|---|---|---|---|"]
        lines += [f"| {r['scene']} | {r['effect']} | {r['region']} | {r['pixels']} | {r['rel_mean']:+.3%} | "
                  f"{r['rel_abs']:.3%} | {r['z']:+.1f} |" for r in rows]
        (args.out / "origin_bias.md").write_text("\n".join(lines) + "\n")
        save_maps(maps, args.out / "origin_bias.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
