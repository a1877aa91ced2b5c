"""Images a run writes: linear OpenEXR plus an sRGB PNG preview, scalar error maps (OpenEXR only: the
report colours them on one scale per grid), and float values for the report's image viewer."""
from __future__ import annotations

import base64
import json
from pathlib import Path

import numpy as np

from ldbench.core.exr import write_exr
from ldbench.core.files import atomic_write, atomic_write_text

from .metrics import to_srgb8
from .signals import deferred_interrupt

# Heavy: Pillow, matplotlib and Mitsuba are imported in the readers and writers that use them; this module is on the
# CLI's start path (through ldbench.core.effects), and `ldbench --help` starts without them.

#: zlib level of the PNG previews (docs/reference/reports.md, "Images": the time it saves)
PNG_COMPRESS_LEVEL = 1


def write_png(path: Path, img: np.ndarray) -> Path:
    """Write 8-bit ``H × W`` (grey), ``H × W × 3`` (RGB) or ``H × W × 4`` (RGBA) pixels to ``path``
    atomically (a temporary file in the same folder, renamed over it)."""
    from PIL import Image

    a = np.asarray(img)
    if a.dtype != np.uint8 or not (a.ndim == 2 or (a.ndim == 3 and a.shape[2] in (1, 3, 4))):
        raise ValueError(f"write_png needs H x W (x 1, 3 or 4) uint8 pixels, got {a.dtype} {a.shape}")
    if a.ndim == 3 and a.shape[2] == 1:
        a = a[:, :, 0]
    im = Image.fromarray(np.ascontiguousarray(a))
    return atomic_write(path, lambda t: im.save(t, format="PNG", compress_level=PNG_COMPRESS_LEVEL))


#: PNG colour types (IHDR) that Pillow, and so matplotlib, reduces to 8 bits at 16-bit depth: grey + alpha,
#: RGB, RGBA (16-bit grey alone is read exactly)
_PNG_16BIT_LOSSY = (2, 4, 6)


def read_png(path: Path) -> np.ndarray:
    """A PNG's pixels as float64 in [0, 1]: ``H × W`` (grey) or ``H × W × C`` (C = 2 grey + alpha, 3 RGB,
    4 RGBA), every code divided by 2^depth - 1 (a palette's entries by 255), exactly at every bit depth. Pillow
    (under matplotlib) keeps only the high byte of a 16-bit colour PNG, so those are decoded with Mitsuba's
    libpng reader; matplotlib scales 2- and 4-bit grey wrongly, so those are read through Pillow alone.
    Raises ``ValueError`` or ``OSError`` when the file is not a readable PNG."""
    path = Path(path)
    with open(path, "rb") as f:
        head = f.read(26)
    if len(head) < 26 or head[:8] != b"\x89PNG\r\n\x1a\n" or head[12:16] != b"IHDR":
        raise ValueError("not a PNG file")
    depth, colour_type = head[24], head[25]
    if depth == 16 and colour_type in _PNG_16BIT_LOSSY:
        with deferred_interrupt():  # Mitsuba's start-up is not safe to interrupt (ldbench/core/signals.py)
            import mitsuba as mi

        try:
            a = np.array(mi.Bitmap(str(path)))
        except RuntimeError as e:  # libpng's complaint about a broken file
            raise ValueError(str(e)) from None
        if a.dtype != np.uint16:
            raise ValueError(f"16-bit PNG decoded as {a.dtype}")
        return a.astype(np.float64) / 65535.0
    if depth < 8 and colour_type == 0:
        # Pillow widens 1-, 2- and 4-bit grey to 8 bits (code × 255 / (2^depth − 1)); matplotlib then divides
        # by 2^depth − 1 instead of 255 (a 4-bit white reads 17): take Pillow's 8-bit codes
        from PIL import Image

        with Image.open(path) as im:
            return np.asarray(im.convert("L"), np.float64) / 255.0
    import matplotlib.image as mpimg

    return np.asarray(mpimg.imread(path), np.float64)


def save_image(path_noext: Path, img: np.ndarray, *, png_scale: float | None = None):
    """EXR (linear float) + PNG preview (sRGB; ``png_scale`` maps that value to white)."""
    path_noext = Path(path_noext)
    chans = {"Y": img[..., 0]} if img.shape[-1] == 1 else dict(zip("RGB", np.moveaxis(img[..., :3], -1, 0)))
    write_exr(str(path_noext) + ".exr", chans)
    disp = img if png_scale in (None, 0) else img / png_scale
    srgb = to_srgb8(disp[..., :1] if disp.shape[-1] == 1 else disp[..., :3])
    write_png(Path(str(path_noext) + ".png"), np.repeat(srgb, 3, -1) if srgb.shape[-1] == 1 else srgb)


def save_map(path_noext: Path, emap: np.ndarray, mask: np.ndarray) -> float:
    """A scalar H×W map as EXR; returns its 99th percentile over ``mask``, the scale a colourised view
    shows as white. No PNG: the report colours the maps of a grid on one scale
    (:func:`ldbench.reports.figures.make_grid`), so a PNG per map on its own scale would be seen by no one."""
    path_noext = Path(path_noext)
    vmax = float(np.percentile(emap[mask], 99)) if mask.any() else 1.0
    write_exr(str(path_noext) + ".exr", {"Y": np.asarray(emap, np.float32)})
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
    a = np.asarray(values, dtype="<f4")
    if a.ndim == 2:
        a = a[..., None]
    h, w, c = a.shape
    if h * w > VALUES_MAX_PIXELS:
        return False
    b64 = base64.b64encode(np.ascontiguousarray(a).tobytes()).decode("ascii")
    atomic_write_text(path, f"ldbenchValues({json.dumps(key)},{w},{h},{c},\"{b64}\");\n")
    return True
