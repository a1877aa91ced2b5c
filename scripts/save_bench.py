"""Time the runner's image files (docs/reference/reports.md, "Images"): an 800² one-channel image and its error map
written as ldbench writes them (``save_image``: EXR + PNG; ``save_map``: EXR) against the same files with
matplotlib's ``imsave`` for the PNGs and an error PNG, as before; the PNGs' sizes; and, with ``--exr``, each
lossless OpenEXR compression's write and read time and size, for the given EXR files (a run's images) or
for the one-channel image and an RGB one.

    python scripts/save_bench.py [--size N] [--repeat R] [--exr [FILE.exr ...]]

The images are a smooth pattern with 5 % uniform noise (renders are smooth plus Monte Carlo noise); its
float noise leaves the EXR compressions little to find, so give real images to compare them.
"""
from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from ldbench.core import imageio
from ldbench.core.exr import read_exr, write_exr
from ldbench.core.metrics import colorize, to_srgb8

#: The lossless compressions every OpenEXR 3 reader decodes (ZSTD and HTJ2K are newer than most viewers).
EXR_COMPRESSIONS = ("NO", "RLE", "ZIPS", "ZIP", "PIZ")


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


def median_ms(fn, repeat: int) -> float:
    ts = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t)
    return 1000 * float(np.median(ts))


def exr_table(folder: Path, images: dict, repeat: int) -> list[str]:
    """Write and read time (median of ``repeat``) and size of each compression, per image."""
    import OpenEXR

    lines = ["| image | compression | write ms | read ms | bytes |", "|---|---|---:|---:|---:|"]
    for name, chans in images.items():
        for c in EXR_COMPRESSIONS:
            hdr = {"compression": getattr(OpenEXR, f"{c}_COMPRESSION"), "type": OpenEXR.scanlineimage}
            p = folder / f"x-{c}.exr"
            # a new dict each time: OpenEXR.File turns the values of the one it gets into its Channel objects
            w = median_ms(lambda: OpenEXR.File(hdr, dict(chans)).write(str(p)), repeat)
            r = median_ms(lambda: read_exr(p), repeat)
            back = read_exr(p)
            assert all(np.array_equal(back[k], v) for k, v in chans.items()), f"{c} is not lossless"
            lines.append(f"| {name} | {c} | {w:.1f} | {r:.1f} | {p.stat().st_size:,} |")
    return lines


def generated(size: int, img, smooth, rng) -> dict:
    """The generated one-channel image and an RGB one like it, as EXR channels."""
    rgb = np.clip(smooth[..., None] * np.array([1.0, 0.8, 0.6]) + 0.05 * rng.random((size, size, 3)),
                  0, None).astype(np.float32)
    return {f"{size}² Y": {"Y": np.ascontiguousarray(img[..., 0])},
            f"{size}² RGB": {c: np.ascontiguousarray(rgb[..., i]) for i, c in enumerate("RGB")}}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=800)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--exr", nargs="*", metavar="FILE.exr", default=None,
                    help="also time each lossless EXR compression, on these files (default: generated images)")
    a = ap.parse_args()
    y, x = np.mgrid[0:a.size, 0:a.size]
    rng = np.random.default_rng(1)
    smooth = 0.5 + 0.5 * np.sin(x / 37.0) * np.cos(y / 23.0)
    img = np.clip(smooth + 0.05 * rng.random((a.size, a.size)), 0, 1)
    img = img[..., None].astype(np.float32)
    emap = np.abs(img[..., 0] - 0.5).astype(np.float32)
    mask = np.ones(emap.shape, bool)
    with tempfile.TemporaryDirectory() as d:
        folder = Path(d)
        for name, fn, stem in (("matplotlib imsave", matplotlib_save, "m"), ("ldbench", ldbench_save, "l")):
            ms = median_ms(lambda: fn(folder, img, emap, mask), a.repeat)
            sizes = [f"{(folder / f'{stem}{s}.png').stat().st_size:,}" if (folder / f"{stem}{s}.png").exists()
                     else "none" for s in ("", "-error")]
            print(f"{name}: {ms:.1f} ms (median of {a.repeat}); PNG bytes {sizes[0]}, error PNG {sizes[1]}")
        if a.exr is not None:
            images = {Path(f).name: read_exr(f) for f in a.exr}
            print("\n".join(exr_table(folder, images or generated(a.size, img, smooth, rng), a.repeat)))


if __name__ == "__main__":
    main()
