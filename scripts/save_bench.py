"""Time the runner's image files (docs/reports.md, "Images"): an 800² one-channel image and its error map
written as ldbench writes them (``save_image`` + ``save_map``: EXR + PNG each) against the same files with
matplotlib's ``imsave`` for the PNGs, as before; and the PNGs' sizes.

    python scripts/save_bench.py [--size N] [--repeat R]

The image is a smooth pattern with 5 % uniform noise (renders are smooth plus Monte Carlo noise).
"""
from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from ldbench.core import imageio
from ldbench.core.exr import write_exr
from ldbench.core.metrics import colorize, to_srgb8


def matplotlib_save(folder: Path, img, emap, mask):
    import matplotlib.image as mpimg

    write_exr(str(folder / "m.exr"), {"Y": img[..., 0]})
    mpimg.imsave(str(folder / "m.png"), to_srgb8(np.repeat(img, 3, -1)))
    vmax = float(np.percentile(emap[mask], 99))
    write_exr(str(folder / "m-error.exr"), {"Y": emap})
    mpimg.imsave(str(folder / "m-error.png"), colorize(emap, vmax=vmax))


def ldbench_save(folder: Path, img, emap, mask):
    imageio.save_image(folder / "l", img)
    imageio.save_map(folder / "l-error", emap, mask)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=800)
    ap.add_argument("--repeat", type=int, default=5)
    a = ap.parse_args()
    y, x = np.mgrid[0:a.size, 0:a.size]
    rng = np.random.default_rng(1)
    img = np.clip(0.5 + 0.5 * np.sin(x / 37.0) * np.cos(y / 23.0) + 0.05 * rng.random((a.size, a.size)), 0, 1)
    img = img[..., None].astype(np.float32)
    emap = np.abs(img[..., 0] - 0.5).astype(np.float32)
    mask = np.ones(emap.shape, bool)
    with tempfile.TemporaryDirectory() as d:
        folder = Path(d)
        for name, fn, stem in (("matplotlib imsave", matplotlib_save, "m"), ("ldbench", ldbench_save, "l")):
            ts = []
            for _ in range(a.repeat):
                t = time.perf_counter()
                fn(folder, img, emap, mask)
                ts.append(time.perf_counter() - t)
            sizes = [(folder / f"{stem}{s}.png").stat().st_size for s in ("", "-error")]
            print(f"{name}: {1000 * np.median(ts):.1f} ms (median of {a.repeat}); PNG bytes {sizes[0]:,}, "
                  f"error PNG {sizes[1]:,}")


if __name__ == "__main__":
    main()
