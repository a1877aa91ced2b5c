"""Closed forms shared by tests: obscurance of a disk above a plane (for AO references and methods)."""
import math

import numpy as np


def disk_occlusion(a, h=1.0, r=1.0, d_max=math.inf, falloff="step", nphi=4096):
    """(1/π)∫ρ(t) cosθ dω over the directions from a plane point (distance a from the disk axis) that
    hit the disk (= 1 − AO; with ``quadratic-second-moment``: 1 − E[V²]). Integrated over the disk in
    polar coordinates about the point's projection: the radial
    integral is closed-form (step: h²/2·[1/(h²+s²)]; quadratic adds −h²/(2d²)·ln(h²+s²)), the angular
    one a 4096-point midpoint rule."""
    a = np.asarray(a, np.float64).reshape(-1)
    phi = (np.arange(nphi) + 0.5) / nphi * 2 * np.pi
    c, s = np.cos(phi)[None], np.sin(phi)[None]
    out = np.empty_like(a)
    for i0 in range(0, len(a), 1024):
        A = a[i0:i0 + 1024, None]
        D = r * r - A * A * s * s
        sq = np.sqrt(np.maximum(D, 0))
        s2 = -A * c + sq
        s1 = np.maximum(0.0, -A * c - sq)
        if math.isfinite(d_max):
            s2 = np.minimum(s2, math.sqrt(max(d_max * d_max - h * h, 0.0)))
        ok = (D > 0) & (s2 > s1)
        h2 = h * h
        g = h2 / 2 * (1 / (h2 + s1 ** 2) - 1 / (h2 + s2 ** 2))
        if falloff == "quadratic":
            g = g - h2 / (2 * d_max ** 2) * np.log((h2 + s2 ** 2) / (h2 + s1 ** 2))
        elif falloff == "quadratic-second-moment":  # E[1 − V²] with V = t²/d_max² on hits
            g = g - h2 / (2 * d_max ** 4) * (s2 ** 2 - s1 ** 2)
        out[i0:i0 + 1024] = np.where(ok, g, 0.0).sum(1) * (2 * np.pi / nphi) / np.pi
    return out
