"""``ldbench run --save-arrays``: the per-ray / per-VPL inputs and answers of non-image effects, the
method's and the oracle's, written beside the row's images as one ``.npz`` (``numpy.load(path)``).

=============  ==============================================================================================
``rays``       inputs ``origin`` (N,3), ``direction`` (N,3), ``tmax`` (N,), ``normal`` (N,3), ``pixel`` (N,)
               (row-major, row 0 at the top); answers ``t`` (the method's; inf = miss, NaN = no answer) and
               ``t_ref`` (the oracle's); ``width``, ``height``, ``kind``
``vpl_range``  VPL inputs ``position``, ``normal``, ``incident``, ``flux``, ``area``, ``texel`` (N), the rays
               ``ray_origin``, ``ray_direction``, ``ray_tmax`` (6N, VPL-major); answers ``range`` /
               ``range_ref`` (N) and ``t`` / ``t_ref`` (6N; the method's ``t`` is NaN where it gave none);
               ``cap``, ``mode``, ``rsm``
=============  ==============================================================================================

How the random numbers of these batches are drawn (seed → directions) is ldbench's ray convention
(docs/reference/rays.md and the ray-conventions module); the arrays make each ray checkable without re-deriving it.
Cost: about 60 bytes per ray (rays) or 150 bytes per VPL (vpl_range), uncompressed: 25 MB for 256² pixels
× 4 rays, 0.5 GB at 1080p × 4 rays. It is off by default for that reason (docs/reference/adapters.md).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ldbench.core.files import atomic_write


def answer_arrays(spec, result, reference, inputs) -> dict | None:
    """{name: array} of one non-image result (module docstring; the effect's ``answer_arrays``); None for
    image effects."""
    return spec.answer_arrays(result, reference, inputs)


def save_arrays(path: Path, arrays: dict) -> Path:
    """``arrays`` as ``path`` (.npz), written under a temporary name and renamed."""
    return atomic_write(path, lambda t: np.savez(t, **arrays), suffix=".npz")
