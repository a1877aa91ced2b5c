"""Image error metrics: PSNR, SSIM, FLIP, relMSE, error maps and previews (pure functions).

Conventions shared by every function here:

* Images are linear float ``H x W x C`` arrays with ``C = 1`` (AO) or ``C = 3`` (radiance); an
  ``H x W`` array is accepted as ``C = 1``. ``test`` and ``ref`` must have the same shape.
* ``mask`` is an ``H x W`` boolean array, True where a pixel is valid (a surface was hit). Only
  unmasked (True) pixels enter a mean. ``mask=None`` means every pixel is valid.
* Before a metric with a spatial support (SSIM windows, FLIP filters) is evaluated, the test image's
  background is replaced by the reference's, so a wrong background can neither add error of its own
  nor leak into foreground pixels near silhouettes. Hence changing the test image's background pixels
  never changes any metric.
* When no pixel is valid, every metric is NaN (there is nothing to compare).
* Non-finite values in ``test`` propagate into the metrics (a NaN from a broken shader gives NaN).
* Bad shapes raise :class:`ldbench.core.errors.LdbenchError`.

:func:`all_metrics` returns the four metrics with the exact settings used, for the result records.
"""
from __future__ import annotations

import math

import numpy as np

from .errors import LdbenchError

# Lazy: scikit-image (it imports scipy) and matplotlib are heavy and this module is on the CLI's start path (through
# ldbench.core.effects); flip_evaluator loads libgomp, which reads OMP_NUM_THREADS once, so it loads only after the
# writer processes set that (ldbench.harness.writers).

#: Default settings of :func:`flip` (recorded by :func:`all_metrics` as ``metric_settings["flip"]``).
#: LDR-FLIP on linear values clipped to [0, 1] (``inputsRGB=False``: FLIP is told the values are
#: linear, not sRGB-encoded), 67 pixels per degree (FLIP's default: 0.7 m from a 0.7 m wide
#: 3840-pixel monitor).
FLIP_SETTINGS = {"mode": "LDR", "ppd": 67.0, "inputs": "linear, clipped to [0, 1]"}

#: SSIM constants (scikit-image's defaults, uniform window, sample covariance).
SSIM_SETTINGS = {"K1": 0.01, "K2": 0.03, "gaussian_weights": False, "use_sample_covariance": True}

ERROR_MAP_KINDS = ("abs", "sq", "relmse")


# --------------------------------------------------------------------------------------------------
# input checks


def _as_hwc(img, name: str) -> np.ndarray:
    a = np.asarray(img)
    if a.ndim == 2:
        a = a[:, :, None]
    if a.ndim != 3:
        raise LdbenchError(f"{name} image must be H x W x C (or H x W), got shape {a.shape}")
    if a.shape[2] not in (1, 3):
        raise LdbenchError(f"{name} image must have 1 or 3 channels, got shape {a.shape}")
    if a.shape[0] == 0 or a.shape[1] == 0:
        raise LdbenchError(f"{name} image is empty, shape {a.shape}")
    if not np.issubdtype(a.dtype, np.number) or np.issubdtype(a.dtype, np.complexfloating):
        raise LdbenchError(f"{name} image must hold real numbers, got dtype {a.dtype}")
    return a.astype(np.float64, copy=False)


def _check(test, ref, mask):
    """Return ``(test, ref, mask)`` as float64 H x W x C, float64 H x W x C, bool H x W."""
    t = _as_hwc(test, "test")
    r = _as_hwc(ref, "reference")
    if t.shape != r.shape:
        raise LdbenchError(f"test image shape {np.shape(test)} differs from reference shape {np.shape(ref)}")
    if mask is None:
        m = np.ones(r.shape[:2], dtype=bool)
    else:
        m = np.asarray(mask)
        if m.shape != r.shape[:2]:
            raise LdbenchError(f"mask shape {m.shape} differs from image size {r.shape[:2]}")
        m = m.astype(bool, copy=False)
    return t, r, m


def _composite(t, r, m):
    """The test image with the reference's background (see the module docstring)."""
    if m.all():
        return t
    return np.where(m[:, :, None], t, r)


def default_data_range(ref, *, mask=None) -> float:
    """Data range used by :func:`psnr` and :func:`ssim` when none is given.

    The maximum of ``ref`` over unmasked pixels and channels (the peak signal of the reference; the
    minimum is taken as 0, as for non-negative radiance and AO). Falls back to 1.0 when that maximum is
    not positive and finite (an all-black reference) or no pixel is valid.

    Parameters
    ----------
    ref : ndarray
        Reference image, ``H x W x C`` or ``H x W``.
    mask : ndarray of bool, optional
        ``H x W``, True for valid pixels.

    Returns
    -------
    float
    """
    _, r, m = _check(ref, ref, mask)
    vals = r[m]
    peak = float(vals.max()) if vals.size else 0.0
    return peak if peak > 0 and math.isfinite(peak) else 1.0


# --------------------------------------------------------------------------------------------------
# metrics


def psnr(test, ref, *, mask=None, data_range=None) -> float:
    """Peak signal-to-noise ratio on linear values, in dB.

    ``PSNR = 10 log10(data_range**2 / MSE)`` with the MSE taken over unmasked pixels and all channels.

    Parameters
    ----------
    test, ref : ndarray
        Linear images, ``H x W x C`` (C = 1 or 3) or ``H x W``, same shape.
    mask : ndarray of bool, optional
        ``H x W``, True for valid pixels; background (False) is excluded.
    data_range : float, optional
        Peak value. Default: :func:`default_data_range` (max of ``ref`` over unmasked pixels).

    Returns
    -------
    float
        ``inf`` when the unmasked pixels are identical, NaN when no pixel is valid.
    """
    t, r, m = _check(test, ref, mask)
    if not m.any():
        return math.nan
    if data_range is None:
        data_range = default_data_range(r, mask=m)
    mse = float(np.mean((t[m] - r[m]) ** 2))
    if mse == 0.0:
        return math.inf
    return float(10.0 * np.log10(float(data_range) ** 2 / mse))


def ssim_win_size(height: int, width: int, win_size: int = 7) -> int:
    """Window size actually used by :func:`ssim`: ``win_size``, or for images smaller than the window
    the largest odd size <= min(height, width).

    Raises
    ------
    LdbenchError
        If ``win_size`` is not an odd integer >= 3, or the image is smaller than 3 x 3.
    """
    if int(win_size) != win_size or win_size < 3 or win_size % 2 == 0:
        raise LdbenchError(f"SSIM win_size must be an odd integer >= 3, got {win_size!r}")
    small = min(height, width)
    if small < 3:
        raise LdbenchError(f"image of {height} x {width} pixels is too small for SSIM (needs >= 3 x 3)")
    if small < win_size:
        win_size = small if small % 2 else small - 1
    return int(win_size)


def ssim_map(test, ref, *, mask=None, data_range=None, win_size=7) -> np.ndarray:
    """Per-pixel SSIM, averaged over channels, ``H x W`` float32 (background set to 0).

    Parameters are those of :func:`ssim`.
    """
    from skimage.metrics import structural_similarity

    t, r, m = _check(test, ref, mask)
    if data_range is None:
        data_range = default_data_range(r, mask=m)
    win = ssim_win_size(r.shape[0], r.shape[1], win_size)
    t = _composite(t, r, m)
    _, smap = structural_similarity(
        t, r, win_size=win, data_range=float(data_range), channel_axis=2, full=True,
        gaussian_weights=SSIM_SETTINGS["gaussian_weights"], K1=SSIM_SETTINGS["K1"], K2=SSIM_SETTINGS["K2"],
        use_sample_covariance=SSIM_SETTINGS["use_sample_covariance"],
    )
    out = smap.mean(axis=2).astype(np.float32)
    out[~m] = 0.0
    return out


def ssim(test, ref, *, mask=None, data_range=None, win_size=7) -> float:
    """Structural similarity, the mean of scikit-image's SSIM map over unmasked pixels.

    ``skimage.metrics.structural_similarity`` with an explicit ``data_range``, ``channel_axis=2``
    (channels are compared separately and averaged), ``full=True``, a uniform ``win_size`` window and
    :data:`SSIM_SETTINGS`. The test image gets the reference's background first (module docstring).
    Unlike scikit-image's own mean, border pixels are not cropped: the map (computed with reflected
    borders) is averaged over every unmasked pixel.

    Parameters
    ----------
    test, ref : ndarray
        Linear images, ``H x W x C`` (C = 1 or 3) or ``H x W``, same shape.
    mask : ndarray of bool, optional
        ``H x W``, True for valid pixels.
    data_range : float, optional
        Default: :func:`default_data_range` (max of ``ref`` over unmasked pixels).
    win_size : int, optional
        Odd window side, default 7; images smaller than it use :func:`ssim_win_size`.

    Returns
    -------
    float
        1 for identical images, NaN when no pixel is valid.
    """
    t, r, m = _check(test, ref, mask)
    if not m.any():
        return math.nan
    smap = ssim_map(t, r, mask=m, data_range=data_range, win_size=win_size)
    return float(np.mean(smap[m], dtype=np.float64))


def flip(test, ref, *, mask=None, hdr=False, pixels_per_degree=67.0):
    """NVIDIA FLIP perceptual error (``flip_evaluator``), masked mean and per-pixel map.

    LDR mode (default) evaluates LDR-FLIP on the linear values clipped to [0, 1], passed to FLIP as
    linear RGB (``inputsRGB=False``); AO images lie in [0, 1] already. HDR mode evaluates HDR-FLIP on
    the linear values clipped below at 0, with FLIP's automatic exposure range (computed over the
    whole image, background included, after the test image gets the reference's background) and ACES
    tone mapping. One-channel images are replicated to three channels.

    Parameters
    ----------
    test, ref : ndarray
        Linear images, ``H x W x C`` (C = 1 or 3) or ``H x W``, same shape.
    mask : ndarray of bool, optional
        ``H x W``, True for valid pixels.
    hdr : bool, optional
        Use HDR-FLIP instead of LDR-FLIP.
    pixels_per_degree : float, optional
        Observer's pixels per degree of visual angle (FLIP's default 67).

    Returns
    -------
    mean : float
        Mean FLIP error over unmasked pixels (0 = identical, 1 = maximal); NaN when none is valid.
    error_map : ndarray
        ``H x W`` float32 FLIP error per pixel, 0 on the background.
    """
    import flip_evaluator

    if not pixels_per_degree > 0:
        raise LdbenchError(f"FLIP pixels_per_degree must be > 0, got {pixels_per_degree!r}")
    t, r, m = _check(test, ref, mask)
    t = _composite(t, r, m)
    if r.shape[2] == 1:
        t, r = np.repeat(t, 3, axis=2), np.repeat(r, 3, axis=2)
    if hdr:
        t, r = np.maximum(t, 0.0), np.maximum(r, 0.0)
        mode, srgb = "HDR", False
    else:
        t, r = np.clip(t, 0.0, 1.0), np.clip(r, 0.0, 1.0)
        mode, srgb = "LDR", False
    emap, _, _ = flip_evaluator.evaluate(
        np.ascontiguousarray(r, dtype=np.float32), np.ascontiguousarray(t, dtype=np.float32), mode,
        inputsRGB=srgb, applyMagma=False, computeMeanError=False,
        parameters={"ppd": float(pixels_per_degree)},
    )
    emap = np.asarray(emap, dtype=np.float32).reshape(r.shape[:2]).copy()
    emap[~m] = 0.0
    mean = float(np.mean(emap[m], dtype=np.float64)) if m.any() else math.nan
    return mean, emap


def relmse(test, ref, *, mask=None, eps=1e-2) -> float:
    """Relative mean squared error: mean over unmasked pixels and channels of
    ``(test - ref)**2 / (ref**2 + eps)``.

    Parameters
    ----------
    test, ref : ndarray
        Linear images, ``H x W x C`` (C = 1 or 3) or ``H x W``, same shape.
    mask : ndarray of bool, optional
        ``H x W``, True for valid pixels.
    eps : float, optional
        Keeps dark reference pixels from dominating, default 1e-2.

    Returns
    -------
    float
        0 for identical images, NaN when no pixel is valid.
    """
    if not eps > 0:
        raise LdbenchError(f"relMSE eps must be > 0, got {eps!r}")
    t, r, m = _check(test, ref, mask)
    if not m.any():
        return math.nan
    tv, rv = t[m], r[m]
    return float(np.mean((tv - rv) ** 2 / (rv ** 2 + eps)))


def all_metrics(test, ref, *, mask=None, data_range=None) -> dict:
    """PSNR, SSIM, FLIP and relMSE with their default settings, and those settings.

    Parameters
    ----------
    test, ref : ndarray
        Linear images, ``H x W x C`` (C = 1 or 3) or ``H x W``, same shape.
    mask : ndarray of bool, optional
        ``H x W``, True for valid pixels.
    data_range : float, optional
        PSNR/SSIM peak; default :func:`default_data_range` (the effect declares it: 1 for AO).

    Returns
    -------
    dict
        ``{"psnr", "ssim", "flip", "relmse": float, "metric_settings": dict}``; ``metric_settings``
        holds the exact data ranges, SSIM window, FLIP mode and pixels per degree, relMSE eps, and the
        number of valid pixels.
    """
    t, r, m = _check(test, ref, mask)
    rule = "given by the effect" if data_range is not None else "max of reference over valid pixels"
    dr = float(data_range) if data_range is not None else default_data_range(r, mask=m)
    win = ssim_win_size(r.shape[0], r.shape[1], 7)
    eps = 1e-2
    ppd = FLIP_SETTINGS["ppd"]
    flip_mean, _ = flip(t, r, mask=m, hdr=False, pixels_per_degree=ppd)
    return {
        "psnr": psnr(t, r, mask=m, data_range=dr),
        "ssim": ssim(t, r, mask=m, data_range=dr, win_size=win),
        "flip": flip_mean,
        "relmse": relmse(t, r, mask=m, eps=eps),
        "metric_settings": {
            "psnr": {"data_range": dr, "data_range_rule": rule},
            "ssim": {"win_size": win, "data_range": dr, **SSIM_SETTINGS,
                     "mean": "SSIM map averaged over channels and valid pixels, no border crop"},
            "flip": dict(FLIP_SETTINGS),
            "relmse": {"eps": eps},
            "mask": "given" if mask is not None else "none",
            "valid_pixels": int(m.sum()),
            "background": "test background replaced by reference background",
        },
    }


# --------------------------------------------------------------------------------------------------
# maps and previews


def error_map(test, ref, *, mask=None, kind="abs") -> np.ndarray:
    """Per-pixel error, averaged over channels, ``H x W`` float32, 0 on the background.

    Parameters
    ----------
    test, ref : ndarray
        Linear images, ``H x W x C`` or ``H x W``, same shape.
    mask : ndarray of bool, optional
        ``H x W``, True for valid pixels.
    kind : {"abs", "sq", "relmse"}
        ``|test - ref|``, ``(test - ref)**2``, or ``(test - ref)**2 / (ref**2 + 1e-2)``.

    Returns
    -------
    ndarray
    """
    t, r, m = _check(test, ref, mask)
    d = t - r
    if kind == "abs":
        e = np.abs(d)
    elif kind == "sq":
        e = d ** 2
    elif kind == "relmse":
        e = d ** 2 / (r ** 2 + 1e-2)
    else:
        raise LdbenchError(f"unknown error map kind {kind!r} (known: {', '.join(ERROR_MAP_KINDS)})")
    out = e.mean(axis=2).astype(np.float32)
    out[~m] = 0.0
    return out


def colorize(map, *, vmax, cmap="magma") -> np.ndarray:
    """Map a scalar ``H x W`` image to colours: ``H x W x 3`` uint8.

    Values are scaled by ``1 / vmax`` and clipped to [0, 1] (0 is the colour map's first colour); NaN
    shows as 0. A ``vmax`` that is not positive maps everything to the first colour.

    Parameters
    ----------
    map : ndarray
        ``H x W`` (or ``H x W x 1``) scalar image, e.g. from :func:`error_map` or :func:`flip`.
    vmax : float
        Value shown with the colour map's last colour.
    cmap : str, optional
        A matplotlib colour map name, default ``"magma"`` (as FLIP uses).
    """
    import matplotlib

    a = np.asarray(map, dtype=np.float64)
    if a.ndim == 3 and a.shape[2] == 1:
        a = a[:, :, 0]
    if a.ndim != 2:
        raise LdbenchError(f"colorize needs an H x W map, got shape {a.shape}")
    try:
        cm = matplotlib.colormaps[cmap]
    except KeyError:
        raise LdbenchError(f"unknown colour map {cmap!r}") from None
    v = float(vmax)
    x = np.clip(np.nan_to_num(a / v, nan=0.0, posinf=1.0, neginf=0.0), 0.0, 1.0) if v > 0 else np.zeros_like(a)
    return (cm(x)[:, :, :3] * 255.0 + 0.5).astype(np.uint8)


def to_srgb8(img) -> np.ndarray:
    """Linear values to 8-bit sRGB (IEC 61966-2-1 transfer curve) for PNG previews.

    Values are clipped to [0, 1] (NaN becomes 0) and rounded; no tone mapping. The shape is kept
    (``H x W``, ``H x W x 1`` or ``H x W x 3``).
    """
    a = np.clip(np.nan_to_num(np.asarray(img, dtype=np.float64), nan=0.0, posinf=1.0, neginf=0.0), 0.0, 1.0)
    s = np.where(a <= 0.0031308, 12.92 * a, 1.055 * np.power(a, 1.0 / 2.4) - 0.055)
    return (s * 255.0 + 0.5).astype(np.uint8)
