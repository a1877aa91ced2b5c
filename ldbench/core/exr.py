"""Small OpenEXR helpers (the ``OpenEXR`` Python package, 3.x) shared by the reference cache and the runner.

Channels are ``H × W`` float32 numpy arrays, row 0 at the top, stored as 32-bit float, ZIP-compressed,
scan-line images. Channel names are free-form; the conventions used by ldbench are ``Y`` for one-channel
images, ``R``/``G``/``B`` for colour, and ``<layer>.<channel>`` (e.g. ``mean.R``, ``variance.Y``) for
several images in one file.

Writes are atomic: the data goes to a temporary file in the destination folder, which is then renamed
over the destination with :func:`os.replace`, so a reader never sees a half-written file.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ldbench.core.errors import LdbenchError
from ldbench.core.files import atomic_write

# Lazy: OpenEXR is imported by _openexr() alone, which turns a broken install into an LdbenchError and keeps the
# native library out of processes that never touch an EXR.

__all__ = ["write_exr", "read_exr", "read_exr_header", "write_image", "read_image", "image_channels"]


def _openexr():
    try:
        import OpenEXR
    except ImportError as e:  # pragma: no cover - dependency listed in pyproject
        raise LdbenchError(f"the OpenEXR Python package is missing ({e}): pip install 'openexr>=3.2'")
    return OpenEXR


def write_exr(path, channels: dict, header: dict | None = None) -> Path:
    """Write ``channels`` (name → ``H × W`` array, converted to float32) to ``path`` atomically.

    ``header`` may add string attributes to the EXR header. Returns the path written.
    """
    OpenEXR = _openexr()
    path = Path(path)
    if not channels:
        raise LdbenchError(f"write_exr {path}: no channels given")
    data, shape = {}, None
    for name, arr in channels.items():
        a = np.ascontiguousarray(np.asarray(arr, dtype=np.float32))
        if a.ndim != 2:
            raise LdbenchError(f"write_exr {path}: channel {name!r} must be H×W, got shape {a.shape}")
        if shape is None:
            shape = a.shape
        elif a.shape != shape:
            raise LdbenchError(f"write_exr {path}: channel {name!r} has shape {a.shape}, expected {shape}")
        data[str(name)] = a
    hdr = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    for k, v in (header or {}).items():
        hdr[str(k)] = str(v)
    try:
        return atomic_write(path, lambda t: OpenEXR.File(hdr, data).write(str(t)), suffix=".exr")
    except OSError as e:
        raise LdbenchError(f"cannot write {path}: {e.strerror or e}")
    except Exception as e:
        raise LdbenchError(f"cannot write {path}: {e}")


def read_exr(path) -> dict:
    """Read every channel of a single-part EXR: name → ``H × W`` float32 array."""
    OpenEXR = _openexr()
    path = Path(path)
    if not path.is_file():
        raise LdbenchError(f"EXR file not found: {path}")
    try:
        with OpenEXR.File(str(path), separate_channels=True) as f:
            return {name: np.asarray(ch.pixels, dtype=np.float32).copy() for name, ch in f.channels().items()}
    except Exception as e:
        raise LdbenchError(f"cannot read EXR {path}: {e}")


def read_exr_header(path) -> dict:
    """The string attributes of an EXR header (e.g. ``ldbench_key``), without decoding any pixels."""
    OpenEXR = _openexr()
    path = Path(path)
    if not path.is_file():
        raise LdbenchError(f"EXR file not found: {path}")
    try:
        f = OpenEXR.File(str(path), header_only=True)
        return {k: v for k, v in f.header().items() if isinstance(v, str)}
    except Exception as e:
        raise LdbenchError(f"cannot read EXR {path}: {e}")


def image_channels(image: np.ndarray, layer: str | None = None) -> dict:
    """Channel dict for an ``H × W × C`` image: C=1 → ``Y``, C=3 → ``R,G,B``, C=4 → ``R,G,B,A``.

    With ``layer`` the names get a prefix (``mean.R``).
    """
    a = np.asarray(image, dtype=np.float32)
    if a.ndim == 2:
        a = a[..., None]
    if a.ndim != 3 or a.shape[2] not in (1, 3, 4):
        raise LdbenchError(f"image must be H×W×C with C in (1, 3, 4), got shape {a.shape}")
    names = {1: "Y", 3: "RGB", 4: "RGBA"}[a.shape[2]]
    pre = f"{layer}." if layer else ""
    return {pre + n: a[..., i] for i, n in enumerate(names)}


def write_image(path, image: np.ndarray, extra: dict | None = None, header: dict | None = None) -> Path:
    """Write an ``H × W × C`` float image (plus optional extra channels) as EXR, atomically."""
    ch = image_channels(image)
    ch.update(extra or {})
    return write_exr(path, ch, header)


def read_answer_channels(path) -> np.ndarray:
    """``H × W × C`` float32 of an image rendered elsewhere (an answer, its variance): channel ``Y``, else
    whichever of ``R``, ``G``, ``B`` it has (one line when it has none)."""
    ch = read_exr(path)
    names = ["Y"] if "Y" in ch else [c for c in "RGB" if c in ch]
    if not names:
        raise LdbenchError(f"{Path(path).name}: no Y or R, G, B channel (has {', '.join(sorted(ch))})")
    return np.stack([np.asarray(ch[c], np.float32) for c in names], -1)


def read_image(path, layer: str | None = None) -> np.ndarray:
    """Read an image written by :func:`write_image` (or a layer of a multi-layer file) as ``H × W × C``."""
    ch = read_exr(path)
    pre = f"{layer}." if layer else ""
    for names in ("RGBA", "RGB", "Y"):
        keys = [pre + n for n in names]
        if all(k in ch for k in keys):
            return np.stack([ch[k] for k in keys], axis=-1)
    raise LdbenchError(f"{path}: no {'layer ' + repr(layer) + ' with ' if layer else ''}Y or R,G,B channels "
                       f"(has {sorted(ch)})")
