"""Brute-force Monte Carlo ``ao`` from ray hit distances: the integrand and per-pixel statistics, shared by
the ``mc-ao`` method (ldbench/methods/mc_ao/) and :mod:`ldbench.references.mc_ao`."""
from __future__ import annotations

import math

import numpy as np


def ao_values(t, d_max: float, falloff: str) -> np.ndarray:
    """Per-ray ``ao`` integrand from a hit distance ``t`` (inf = miss): 1 when the ray escapes ``d_max``; on a
    hit 0 (``step``, or ``d_max`` = inf) or (t/d_max)² (``quadratic``)."""
    t = np.asarray(t, np.float64)
    hit = np.isfinite(t) & (t < d_max)
    if falloff == "step" or math.isinf(d_max):
        return np.where(hit, 0.0, 1.0)
    return np.where(hit, np.square(np.where(hit, t, 0.0) / d_max), 1.0)


def pixel_mean_variance(values, pixel, spp: int, width: int, height: int, background: float = 1.0):
    """(mean, variance of the mean), H×W×1 float32, of ``spp`` consecutive samples per pixel (``pixel`` the
    row-major pixel index of each sample, pixel-major order); other pixels hold ``background``, variance 0.
    The variance of the mean is the unbiased sample variance / spp (spp ≥ 2)."""
    v = np.asarray(values, np.float64).reshape(-1, spp)
    pix = np.asarray(pixel).reshape(-1, spp)[:, 0]
    mean, var = np.full(width * height, float(background)), np.zeros(width * height)
    mean[pix] = v.mean(1)
    var[pix] = v.var(1, ddof=1) / spp
    shape = (height, width, 1)
    return mean.reshape(shape).astype(np.float32), var.reshape(shape).astype(np.float32)
