"""Images a run writes: linear OpenEXR plus an sRGB PNG preview, scalar error maps, and float values
for the report's image viewer."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np


def save_image(path_noext: Path, img: np.ndarray, *, png_scale: float | None = None):
    """EXR (linear float) + PNG preview (sRGB; ``png_scale`` maps that value to white)."""
    import matplotlib.image as mpimg

    from ldbench.core.exr import write_exr

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

    from ldbench.core.exr import write_exr

    from .metrics import colorize

    path_noext = Path(path_noext)
    path_noext.parent.mkdir(parents=True, exist_ok=True)
    vmax = float(np.percentile(emap[mask], 99)) if mask.any() else 1.0
    write_exr(str(path_noext) + ".exr", {"Y": np.asarray(emap, np.float32)})
    mpimg.imsave(str(path_noext) + ".png", colorize(emap, vmax=max(vmax, 1e-6)))
    return vmax


#: Largest image (pixels) whose float values the report writes for the viewer's per-pixel read-out.
VALUES_MAX_PIXELS = 1 << 20


def save_values_js(path: Path, key: str, values: np.ndarray) -> bool:
    """Write an image's float32 values as a small script for the report's viewer.

    The file calls ``ldbenchValues(key, width, height, channels, base64)`` with the little-endian
    float32 pixels (row-major, channels last). A script, not a raw ``.f32`` fetched by the page,
    because browsers block ``fetch`` of ``file://`` URLs while ``<script src>`` still loads, so the
    exact values reach the page opened straight from disk. Images over :data:`VALUES_MAX_PIXELS`
    are skipped (returns False): the viewer then shows coordinates only.
    """
    import base64

    a = np.asarray(values, dtype="<f4")
    if a.ndim == 2:
        a = a[..., None]
    h, w, c = a.shape
    if h * w > VALUES_MAX_PIXELS:
        return False
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    b64 = base64.b64encode(np.ascontiguousarray(a).tobytes()).decode("ascii")
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(f"ldbenchValues({json.dumps(key)},{w},{h},{c},\"{b64}\");\n", encoding="ascii")
    tmp.replace(path)
    return True
