"""Is an answer unbiased? A per-pixel two-sided test of an image against the reference, within both noises.

The question: is the answer's per-pixel expectation the reference's? Each image is a Monte Carlo mean with
a per-pixel **variance of the mean** (the sample variance divided by the sample count: what
:mod:`ldbench.references.render` stores). Per pixel ``i`` and channel ``c``

    d = a − r,     s² = var_a + var_r,     z = d / s                                 (Welch's statistic)

and the two-sided p-value ``p = 2 · sf(|z|)``: Student's t with the Welch–Satterthwaite degrees of freedom
when both sample counts are known, the standard normal otherwise. A pixel's channels are one hypothesis:
``p_pixel = 1 − (1 − min_c p_c)^C`` (Šidák over the ``C`` channels, valid for the positively dependent
two-sided tests of one pixel's colour). Pixels with no information (both variances 0: a deterministic
effect such as ``direct``, background, a fully occluded point) are compared exactly: p = 1 when equal, 0
otherwise. A NaN or infinite value or variance, or a pixel the answer left out where the reference sees a
surface, gets p = 0: it rejects.

The family of ``m`` pixels is judged three ways, each at the family-wise level α:

- ``p_family``: the smallest pixel p corrected for ``m`` tests, Šidák ``1 − (1 − p_min)^m`` (per-pixel
  threshold ``1 − (1 − α)^(1/m)``) or Holm (step-down; for the smallest p it is Bonferroni, ``m · p_min``).
  It detects a large bias on a few pixels.
- ``p_count``: the number ``k`` of pixels with p < α against Binomial(m_noisy, α) (one-sided: too many),
  ``m_noisy`` the pixels with a positive variance. ``rejected_fraction = k / m`` is to be read against
  ``expected_fraction = α``.
- ``p_mean``: a two-sided z test of the summed difference over the noisy pixels,
  ``Z = Σ d̄ / sqrt(Σ s̄²)`` with ``d̄`` the channel mean of ``d`` and ``s̄`` the channel mean of ``s`` per
  pixel (``s̄²`` bounds the variance of ``d̄`` whatever the correlation of the channels, so Z is
  conservative for colour). It detects a small bias of one sign spread over the image (0.5 % is far below
  one pixel's noise, but many standard errors of the sum over 10⁴ pixels). Its weights do not depend on
  the data, so E[Z] = 0 exactly for unbiased images, unlike a mean of per-pixel z-scores, which skewed
  integrands (binary visibility) bias when the two sample counts differ.

``unbiased_p = min(1, 3 · min(p_family, p_count, p_mean))`` (Bonferroni over the three) and the verdict is
``"pass"`` when ``unbiased_p ≥ α``, so an unbiased answer fails with probability at most about α.
Everything here is pure numpy/scipy; values are linear radiance or AO in any range (no clipping).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from ldbench.core.errors import LdbenchError

CORRECTIONS = ("sidak", "holm")
DEFAULT_ALPHA = 0.01

#: Codes of :attr:`UnbiasedResult.reject_map`.
NOT_TESTED, ACCEPT, REJECT_PIXEL, REJECT_FAMILY, INVALID = 0, 1, 2, 3, 4


def variance_of_mean(mean, second_moment, n):
    """The variance of the mean from a sample count and the first two raw moments.

    Parameters
    ----------
    mean, second_moment : array_like
        Per-pixel sample mean ``S₁/n`` and mean of the squares ``S₂/n`` of the ``n`` samples (any range).
    n : int or array_like
        Samples per pixel, ≥ 2.

    Returns
    -------
    ndarray (float64)
        ``(S₂/n − (S₁/n)²) · n/(n − 1) / n`` = the unbiased sample variance divided by ``n``; negative
        round-off is clipped to 0.
    """
    n = np.asarray(n, np.float64)
    if np.any(n < 2):
        raise LdbenchError(f"the variance of the mean needs at least 2 samples per pixel, got {np.min(n):g}")
    m1 = np.asarray(mean, np.float64)
    m2 = np.asarray(second_moment, np.float64)
    sample_var = (m2 - m1 * m1) * n / (n - 1.0)
    return np.maximum(sample_var, 0.0) / n


def welch_df(var_a, n_a, var_b, n_b):
    """Welch–Satterthwaite degrees of freedom of ``(a − b) / sqrt(var_a + var_b)``.

    ``var_*`` are variances of the means (≥ 0), ``n_*`` sample counts (≥ 2); where both variances are 0 the
    result is ∞ (the caller compares those pixels exactly).
    """
    va, vb = np.asarray(var_a, np.float64), np.asarray(var_b, np.float64)
    den = va * va / (n_a - 1.0) + vb * vb / (n_b - 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(den > 0, (va + vb) ** 2 / np.where(den > 0, den, 1.0), np.inf)


def two_sided_p(z, df=None):
    """Two-sided p-value of a statistic ``z``: ``2 · sf(|z|)`` of N(0, 1) (``df`` None) or Student's t."""
    z = np.abs(np.asarray(z, np.float64))
    if df is None:
        return 2.0 * stats.norm.sf(z)
    df = np.broadcast_to(np.asarray(df, np.float64), z.shape)
    return np.where(np.isinf(df), 2.0 * stats.norm.sf(z), 2.0 * stats.t.sf(z, np.where(np.isinf(df), 1.0, df)))


def sidak_threshold(alpha: float, m: int) -> float:
    """Per-test level that keeps the family-wise level at ``alpha`` over ``m`` independent tests:
    ``1 − (1 − α)^(1/m)``."""
    return float(-np.expm1(np.log1p(-alpha) / m))


def sidak_adjust(p, m):
    """Šidák-adjusted p-values ``1 − (1 − p)^m`` (computed without cancellation)."""
    p = np.clip(np.asarray(p, np.float64), 0.0, 1.0)
    with np.errstate(divide="ignore"):
        return -np.expm1(m * np.log1p(-p))


def holm_adjust(p):
    """Holm's step-down adjusted p-values of a flat array (same order as ``p``)."""
    p = np.asarray(p, np.float64).ravel()
    m = len(p)
    order = np.argsort(p, kind="stable")
    adj = np.minimum(1.0, np.maximum.accumulate((m - np.arange(m)) * p[order]))
    out = np.empty(m)
    out[order] = adj
    return out


@dataclass
class UnbiasedResult:
    """The outcome of :func:`unbiased_test`. Maps are H×W; ``p_map`` is NaN where not tested."""

    verdict: str                 # "pass" or "fail"
    unbiased_p: float
    p_family: float
    p_count: float
    p_mean: float
    rejected_fraction: float     # pixels with p < α (uncorrected), over the tested pixels
    expected_fraction: float     # α
    tested: int
    noisy: int                   # tested pixels with a positive variance
    invalid: int                 # NaN / infinite / missing pixels (they reject)
    alpha: float
    correction: str
    p_map: np.ndarray = field(repr=False)
    adjusted_map: np.ndarray = field(repr=False)
    reject_map: np.ndarray = field(repr=False)

    def columns(self) -> dict:
        """The results columns (docs/reference/results-columns.md)."""
        return {"unbiased_p": self.unbiased_p, "unbiased_verdict": self.verdict,
                "rejected_fraction": self.rejected_fraction, "expected_fraction": self.expected_fraction,
                "unbiased_p_family": self.p_family, "unbiased_p_count": self.p_count,
                "unbiased_p_mean": self.p_mean, "unbiased_pixels": self.tested,
                "unbiased_invalid": self.invalid, "unbiased_alpha": self.alpha,
                "unbiased_correction": self.correction}


def _hwc(a, name):
    a = np.asarray(a, np.float64)
    if a.ndim == 2:
        a = a[..., None]
    if a.ndim != 3:
        raise LdbenchError(f"{name}: expected an H×W or H×W×C image, got shape {a.shape}")
    return a


def unbiased_test(answer, answer_var, reference, reference_var, *, n_answer=None, n_reference=None,
                  mask=None, missing=None, alpha: float = DEFAULT_ALPHA, correction: str = "sidak"):
    """Test ``answer`` against ``reference`` (module docstring).

    Parameters
    ----------
    answer, reference : array_like, H×W or H×W×C
        Per-pixel Monte Carlo means (linear values, any range).
    answer_var, reference_var : array_like, same shape
        Their variances of the mean (≥ 0; 0 = exact).
    n_answer, n_reference : int, optional
        Sample counts; with both, Student's t with Welch's degrees of freedom, else the normal.
    mask : array_like of bool, H×W, optional
        The pixels tested (default all).
    missing : array_like of bool, H×W, optional
        Tested pixels the answer gave no value: they reject.
    alpha : float in (0, 1)
        Family-wise level.
    correction : {"sidak", "holm"}

    Returns
    -------
    UnbiasedResult
    """
    if not (isinstance(alpha, (int, float)) and 0.0 < float(alpha) < 1.0):
        raise LdbenchError(f"alpha must be a number in (0, 1), got {alpha!r}")
    if correction not in CORRECTIONS:
        raise LdbenchError(f"correction must be one of {', '.join(CORRECTIONS)}, got {correction!r}")
    alpha = float(alpha)
    a, va = _hwc(answer, "answer"), _hwc(answer_var, "answer variance")
    r, vr = _hwc(reference, "reference"), _hwc(reference_var, "reference variance")
    if r.shape[-1] == 1 and a.shape[-1] == 3:
        r, vr = np.repeat(r, 3, -1), np.repeat(vr, 3, -1)
    for name, x in (("answer", a), ("answer variance", va), ("reference variance", vr)):
        if x.shape != r.shape:
            raise LdbenchError(f"{name} has shape {x.shape}, the reference {r.shape}")
    H, W, C = r.shape
    tested = np.ones((H, W), bool) if mask is None else np.asarray(mask, bool)
    bad = ~(np.isfinite(a) & np.isfinite(va) & np.isfinite(r) & np.isfinite(vr) & (va >= 0) & (vr >= 0)).all(-1)
    if missing is not None:
        bad |= np.asarray(missing, bool)
    bad &= tested
    s2 = np.where(bad[..., None], 1.0, va + vr)
    d = np.where(bad[..., None], 0.0, a - r)
    noisy_c = s2 > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(noisy_c, d / np.sqrt(np.where(noisy_c, s2, 1.0)), 0.0)
    df = None
    if n_answer is not None and n_reference is not None:
        df = welch_df(va, float(n_answer), vr, float(n_reference))
    p_c = np.where(noisy_c, two_sided_p(z, df), np.where(d == 0, 1.0, 0.0))  # exact where both variances are 0
    p = sidak_adjust(p_c.min(-1), C)                                          # one pixel, C channels
    p[bad] = 0.0
    p_map = np.where(tested, p, np.nan)
    pt = p[tested]
    m = int(tested.sum())
    noisy = tested & ~bad & noisy_c.any(-1)
    m_noisy = int(noisy.sum())
    if m == 0:
        raise LdbenchError("the unbiasedness test has no pixel to test (the camera sees no geometry)")
    adjusted = np.full((H, W), np.nan)
    if correction == "sidak":
        adjusted[tested] = sidak_adjust(pt, m)
    else:
        adjusted[tested] = holm_adjust(pt)
    p_family = float(np.nanmin(adjusted))
    k = int((pt < alpha).sum())
    p_count = float(stats.binom.sf(k - 1, m_noisy, alpha)) if k > 0 else 1.0
    if m_noisy > 0:  # the summed difference over its standard deviation (a channel mean per pixel)
        dbar = d[noisy].mean(-1)
        sbar = np.sqrt(s2[noisy]).mean(-1)  # ≥ the sd of dbar whatever the channels' correlation
        p_mean = float(two_sided_p(dbar.sum() / np.sqrt(np.sum(sbar * sbar))))
    else:
        p_mean = 1.0
    unbiased_p = float(min(1.0, 3.0 * min(p_family, p_count, p_mean)))
    codes = np.full((H, W), NOT_TESTED, np.uint8)
    codes[tested] = ACCEPT
    codes[tested & (p < alpha)] = REJECT_PIXEL
    codes[tested & (np.nan_to_num(adjusted, nan=1.0) < alpha)] = REJECT_FAMILY
    codes[bad] = INVALID
    return UnbiasedResult(verdict="pass" if unbiased_p >= alpha else "fail", unbiased_p=unbiased_p,
                          p_family=p_family, p_count=p_count, p_mean=p_mean, rejected_fraction=k / m,
                          expected_fraction=alpha, tested=m, noisy=m_noisy, invalid=int(bad.sum()), alpha=alpha,
                          correction=correction, p_map=p_map, adjusted_map=adjusted, reject_map=codes)


#: RGB of each code of the rejection map (not tested, accept, p < α, rejected after correction, invalid).
REJECT_COLOURS = np.array([[0, 0, 0], [70, 70, 70], [255, 170, 0], [230, 20, 20], [40, 110, 255]], np.uint8)


def reject_map_rgb(codes) -> np.ndarray:
    """H×W×3 uint8 picture of :attr:`UnbiasedResult.reject_map` (:data:`REJECT_COLOURS`)."""
    return REJECT_COLOURS[np.asarray(codes, np.uint8)]
