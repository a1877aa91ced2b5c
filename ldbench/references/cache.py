"""On-disk cache of references: ``<cache_dir>/<key>.exr`` + ``<key>.json``.

The key is the SHA-256 (first 24 hex digits) of the JSON of: the scene's ``content_hash()``, the
effect's ``key()``, width, height, the effective spp, seed, the Mitsuba version, the variant and
:data:`REFERENCE_VERSION`. The EXR holds the layers ``mean.*`` and ``variance.*`` (``Y`` for ``ao``,
``R,G,B`` otherwise) and the channel ``mask`` (1 = hit); the JSON holds the key fields and the meta of
the render. Both files are written atomically (temporary file in the same folder + ``os.replace``),
the EXR first, so a JSON file always describes a complete EXR. The EXR header carries the key
(``ldbench_key``); an entry is used only when the file name, the JSON and the EXR header all name the
same key, and its pixels are what was stored: the JSON and the EXR header (``ldbench_pixels``) carry
the SHA-256 of the float32 mean, variance and mask (:func:`pixels_digest`), and every mean and
variance value is finite. A missing, unreadable, mismatching or damaged entry is a cache miss, never
an error.

``cache_dir`` defaults to ``$LDBENCH_CACHE``, else ``<repo>/.cache/references/`` in a checkout, else the user
cache (:func:`default_cache_dir`).
"""
from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

import numpy as np

from ldbench.core.errors import LdbenchError
from ldbench.core.files import atomic_write_text

from ldbench.core.exr import image_channels, read_exr, read_exr_header, write_exr

# Bump whenever an integrator changes what it computes (invalidates every cached reference).
REFERENCE_VERSION = 3  # 3: secondary rays at Mitsuba's spawn offset of the crease point (2: nudged to the camera)


def default_cache_dir() -> Path:
    """``$LDBENCH_CACHE``; else ``.cache/references`` of a source checkout; else (an installed wheel,
    whose package folder may not be writable) the user cache: ``$XDG_CACHE_HOME/ldbench/references``."""
    env = os.environ.get("LDBENCH_CACHE")
    if env:
        return Path(env).expanduser()
    root = Path(__file__).resolve().parents[2]  # ldbench/references/cache.py -> the checkout
    if (root / "pyproject.toml").is_file():
        return root / ".cache" / "references"
    xdg = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(xdg) / "ldbench" / "references"


def key_fields(scene, effect, width, height, spp, seed, mitsuba_version, variant) -> dict:
    return {
        "scene": scene.content_hash(),
        "scene_name": scene.name,
        "effect": effect.key(),
        "width": int(width),
        "height": int(height),
        "spp": int(spp),
        "seed": int(seed),
        "mitsuba_version": str(mitsuba_version),
        "variant": str(variant),
        "reference_version": REFERENCE_VERSION,
    }


def cache_key(fields: dict) -> str:
    f = {k: v for k, v in fields.items() if k != "scene_name"}  # the name is informative only
    return hashlib.sha256(json.dumps(f, sort_keys=True).encode()).hexdigest()[:24]


def pixels_digest(mean, variance, mask) -> str:
    """SHA-256 of an entry's pixel data as stored (float32 mean, variance and mask, with their shapes)."""
    h = hashlib.sha256()
    for a in (mean, variance, mask):
        a = np.ascontiguousarray(np.asarray(a, np.float32))
        h.update(repr(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()


def store(cache_dir, key: str, fields: dict, mean, variance, mask, meta: dict) -> Path:
    """Write the entry; returns the EXR path. Raises LdbenchError if the folder is not writable."""
    d = Path(cache_dir)
    try:
        d.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise LdbenchError(f"cannot create reference cache folder {d}: {e.strerror or e}")
    ch = image_channels(mean, "mean")
    ch.update(image_channels(variance, "variance"))
    ch["mask"] = mask.astype(np.float32)
    digest = pixels_digest(mean, variance, ch["mask"])
    exr = d / f"{key}.exr"
    write_exr(exr, ch, header={"ldbench_key": key, "ldbench_pixels": digest})
    doc = {"key": key, "fields": fields, "meta": {k: v for k, v in meta.items() if k != "cached"},
           "channels": mean.shape[2], "shape": [int(mean.shape[0]), int(mean.shape[1])], "pixels": digest}
    try:
        atomic_write_text(d / f"{key}.json", json.dumps(doc, indent=2, sort_keys=True, default=str))
    except OSError as e:
        raise LdbenchError(f"cannot write {d / (key + '.json')}: {e.strerror or e}")
    return exr


def load(cache_dir, key: str, fields: dict):
    """(mean, variance, mask, meta) of a complete matching entry, or None."""
    d = Path(cache_dir)
    exr, js = d / f"{key}.exr", d / f"{key}.json"
    if not (exr.is_file() and js.is_file()):
        return None
    try:
        doc = json.loads(js.read_text())
        if doc.get("key") != key or cache_key(doc.get("fields", {})) != key:
            return None
        header = read_exr_header(exr)
        if header.get("ldbench_key") != key:  # e.g. another entry's EXR copied over it
            return None
        ch = read_exr(exr)
        names = "Y" if int(doc["channels"]) == 1 else "RGB"
        mean = np.stack([ch[f"mean.{c}"] for c in names], -1).astype(np.float32)
        var = np.stack([ch[f"variance.{c}"] for c in names], -1).astype(np.float32)
        mask_f = np.asarray(ch["mask"], np.float32)
        mask = mask_f > 0.5
        if list(mean.shape[:2]) != doc["shape"] or mean.shape[:2] != (fields["height"], fields["width"]):
            return None
        digest = pixels_digest(mean, var, mask_f)  # pixels edited or damaged since they were stored
        if not (doc.get("pixels") == header.get("ldbench_pixels") == digest):
            return None
        if not (np.isfinite(mean).all() and np.isfinite(var).all()):
            return None
    except (LdbenchError, OSError, ValueError, KeyError, TypeError):
        return None
    return mean, var, mask, dict(doc.get("meta", {}))
