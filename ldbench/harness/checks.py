"""Input checks that need the loaded scenes or the references (the suite itself is checked earlier,
by :mod:`ldbench.harness.suite`). Each raises a one-line :class:`~ldbench.core.errors.LdbenchError` before any
method renders, or returns a corrected value.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ldbench.core.errors import LdbenchError


def unique_scene_names(scenes: dict) -> dict:
    """``scenes`` ({job.scene_key: Scene}) with a unique name per scene file.

    Two different files of one name (``a/scene.xml``, ``b/scene.xml``) would share ``images/scene/``
    and the ``scene`` column. Every scene whose name is shared by another source gets
    ``NAME-<first 6 hex digits of its content hash>`` (stable across runs, so ``compare`` still
    matches). One builder with several parameter sets keeps its name: its image names carry a tag.
    """
    sources: dict = {}
    for (spec, _), sc in scenes.items():
        sources.setdefault(sc.name, set()).add(spec)
    out = {}
    for key, sc in scenes.items():
        if len(sources[sc.name]) > 1:
            sc = dataclasses.replace(sc, name=f"{sc.name}-{sc.content_hash()[:6]}")
        out[key] = sc
    return out


def camera_sees_geometry(scene, reference, width: int, height: int) -> None:
    """Refuse a scene of which the reference's primary rays hit nothing (``reference.mask`` empty):
    every metric would be undefined (NaN), never a result to record as ``ok``."""
    mask = getattr(reference, "mask", None)
    if mask is not None and not np.asarray(mask).any():
        raise LdbenchError(f"scene {scene.name!r}: the camera sees no geometry at {width}x{height} "
                           f"(camera facing away, or only zero-area / zero-scale meshes)")


def finite_reference(scene, reference, label: str) -> None:
    """Refuse a reference image with a NaN or infinite value (mean or variance) where the camera sees
    a surface: every row scored against it would be ``ok`` with NaN metrics. With one sample per pixel
    the variance of the mean is unknown (NaN by definition), so only the mean is checked then."""
    if getattr(reference, "mean", None) is None:
        return

    def nonfinite(a):  # per pixel: any channel
        b = ~np.isfinite(np.asarray(a))
        return b.any(-1) if b.ndim == 3 else b

    bad = nonfinite(reference.mean)
    spp = (getattr(reference, "meta", None) or {}).get("spp")
    if getattr(reference, "variance", None) is not None and not (spp is not None and spp < 2):
        bad = bad | nonfinite(reference.variance)
    mask = getattr(reference, "mask", None)
    n = int(bad[np.asarray(mask, bool)].sum() if mask is not None else bad.sum())
    if n:
        raise LdbenchError(f"scene {scene.name!r}: the reference of {label} has {n} non-finite pixel(s); "
                           f"not scoring against it (rerun with a fresh reference cache)")
