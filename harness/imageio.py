"""Images a run writes: linear OpenEXR plus an sRGB PNG preview, and scalar error maps."""
from __future__ import annotations

from pathlib import Path

import numpy as np


def save_image(path_noext: Path, img: np.ndarray, *, png_scale: float | None = None):
    """EXR (linear float) + PNG preview (sRGB; ``png_scale`` maps that value to white)."""
    import matplotlib.image as mpimg

    from references.exr import write_exr

    from .metrics import to_srgb8

    path_noext = Path(path_noext)
    path_noext.parent.mkdir(parents=True, exist_ok=True)
    chans = {"Y": img[..., 0]} if img.shape[-1] == 1 else dict(zip("RGB", np.moveaxis(img[..., :3], -1, 0)))
    write_exr(str(path_noext) + ".exr", chans)
    disp = img if png_scale in (None, 0) else img / png_scale
    rgb = np.repeat(disp, 3, -1) if disp.shape[-1] == 1 else disp[..., :3]
    mpimg.imsave(str(path_noext) + ".png", to_srgb8(rgb))


def save_map(path_noext: Path, emap: np.ndarray, mask: np.ndarray) -> float:
    """A scalar H×W map as EXR + colourised PNG (magma, white = its 99th percentile over ``mask``).
    Returns that scale."""
    import matplotlib.image as mpimg

    from references.exr import write_exr

    from .metrics import colorize

    path_noext = Path(path_noext)
    path_noext.parent.mkdir(parents=True, exist_ok=True)
    vmax = float(np.percentile(emap[mask], 99)) if mask.any() else 1.0
    write_exr(str(path_noext) + ".exr", {"Y": np.asarray(emap, np.float32)})
    mpimg.imsave(str(path_noext) + ".png", colorize(emap, vmax=max(vmax, 1e-6)))
    return vmax
