"""The statistics of the gate: the time test (one-sided Mann-Whitney U with a minimum effect), the
quality bound from the references' own Monte Carlo noise (:func:`noise_bound`, :func:`quality_thresholds`)
and the fixed tolerances of non-image metrics (:func:`metric_check`)."""
from __future__ import annotations

import math

import numpy as np
from scipy.stats import mannwhitneyu

from .match import as_float, row_value
from .verdicts import Check, Thresholds

def frame_samples(row) -> list:
    raw = row_value(row, "raw_ms") or {}
    if not isinstance(raw, dict):
        return []
    s = raw.get("total") or raw.get("wall") or []
    return [float(x) for x in s if x is not None and math.isfinite(float(x))]


def min_p_value(n: int, m: int) -> float:
    """Smallest one-sided p-value the exact Mann-Whitney U test can give for n and m samples."""
    return 1.0 / math.comb(n + m, n) if n and m else 1.0


def time_check(base_samples, run_samples, th: Thresholds) -> dict:
    """Mann-Whitney U test of run > baseline plus the minimum effect size.

    Returns ``{"verdict", "p", "p_faster", "change", "note"}``; ``change`` = median(run)/median(base) - 1.
    """
    b = np.asarray(base_samples, float)
    r = np.asarray(run_samples, float)
    if b.size == 0 or r.size == 0:
        return {"verdict": "n/a", "p": math.nan, "p_faster": math.nan, "change": math.nan,
                "note": "no per-frame samples"}
    mb, mr = float(np.median(b)), float(np.median(r))
    change = mr / mb - 1.0 if mb > 0 else (math.inf if mr > 0 else 0.0)
    if min_p_value(b.size, r.size) >= th.alpha:
        return {"verdict": "inconclusive", "p": math.nan, "p_faster": math.nan, "change": change,
                "note": f"{b.size}+{r.size} frames cannot reach p<{th.alpha:g}"}
    if np.ptp(np.concatenate([b, r])) == 0:
        p_slow = p_fast = 1.0
    else:
        p_slow = float(mannwhitneyu(r, b, alternative="greater").pvalue)
        p_fast = float(mannwhitneyu(r, b, alternative="less").pvalue)
    if p_slow < th.alpha and change >= th.min_effect:
        verdict = "regression"
    elif p_fast < th.alpha and change <= -th.min_effect:
        verdict = "improved"
    else:
        verdict = "ok"
    return {"verdict": verdict, "p": p_slow, "p_faster": p_fast, "change": change, "note": ""}



# --------------------------------------------------------------------------------------------------
# quality


def _ref_noise(row) -> tuple[float, bool]:
    """(sigma, known): RMS over foreground pixels of the std-dev of the reference mean."""
    rn = row_value(row, "ref_noise")
    if isinstance(rn, dict):
        v = rn.get("rms_std_of_mean")
        if v is not None and math.isfinite(float(v)) and float(v) >= 0:
            return float(v), True
    return 0.0, False


def _settings(row) -> dict:
    ms = row_value(row, "metric_settings")
    return ms if isinstance(ms, dict) else {}


def _data_range(row) -> float:
    given = (_settings(row).get("psnr") or {}).get("data_range")
    if not isinstance(given, (int, float, str)):
        return 1.0
    try:
        d = float(given)
    except ValueError:
        return 1.0
    return d if d > 0 and math.isfinite(d) else 1.0


def _valid_pixels(row) -> int:
    n = _settings(row).get("valid_pixels")
    if n:
        return max(int(n), 1)
    w, h = row_value(row, "width"), row_value(row, "height")
    return max(int(w or 1) * int(h or 1), 1)


def mse_from_psnr(psnr: float, data_range: float) -> float:
    """MSE = D^2 10^(-PSNR/10) (0 for an infinite PSNR)."""
    if math.isinf(psnr) and psnr > 0:
        return 0.0
    return data_range ** 2 * 10.0 ** (-psnr / 10.0)


def noise_bound(*, sigma_b: float, sigma_r: float, rmse_b: float, rmse_r: float, n: int,
                same_reference: bool, z: float = 3.0) -> float:
    """Bound ``B`` on how much the measured MSE of RUN can exceed BASELINE's through the Monte Carlo
    noise of the references alone, at ``z`` standard deviations.

    Derivation. The reference is ``R = T + eps``: ``T`` the converged image, ``eps`` its Monte Carlo
    error, zero-mean, independent between pixels (independent samples per pixel), with per-pixel
    variance ``s_i^2`` (the stored variance of the mean); ``sigma^2 = mean_i s_i^2`` over the ``N``
    foreground pixels is ``ref_noise["rms_std_of_mean"]**2``. A method image ``X`` has true error
    ``e = X - T`` and measured error ``r = X - R = e - eps``, so its measured MSE is::

        m = mean(e^2) - 2 mean(e eps) + mean(eps^2).

    *Same reference* (equal ``ref_key``: the cached reference is reused). With ``d = X_run - X_base``::

        m_run - m_base = [mean(e_run^2) - mean(e_base^2)]  -  2 mean(d eps).

    The bracket is the true change; the last term is what the reference's noise adds. Cauchy-Schwarz
    bounds it by ``2 sigma rms(d)`` (the "2 sigma_ref rmse" rule of thumb), but that is reached only if
    the methods' difference were aligned with the reference's noise, which they never see. Given
    ``d``, the term is a sum of ``N`` independent zero-mean terms, with variance
    ``4/N^2 sum_i d_i^2 s_i^2 ~= 4 sigma^2 mean(d^2) / N``; and ``rms(d) <= rmse_base + rmse_run``
    (triangle inequality, ``d = r_run - r_base``). Hence, at ``z`` standard deviations::

        B_same = 2 z sigma (rmse_base + rmse_run) / sqrt(N).

    *Different references* (re-rendered, other spp or variant): the noise floor ``mean(eps^2)`` no
    longer cancels. Its expectation is ``sigma^2``, so a noisier run reference raises the run's MSE by
    ``sigma_run^2 - sigma_base^2`` with identical images (only an increase can fake a regression);
    each ``mean(eps^2)`` fluctuates by ``sigma^2 sqrt(2/N)`` (Gaussian eps: var(eps^2) = 2 s^4), and
    each cross term ``2 mean(e eps)`` by ``2 sigma rmse / sqrt(N)`` as above::

        B_diff = max(sigma_run^2 - sigma_base^2, 0)
                 + 2 z (sigma_base rmse_base + sigma_run rmse_run) / sqrt(N)
                 + z sqrt(2/N) (sigma_base^2 + sigma_run^2).

    The measured RMSE stands in for the true one (it is larger by the noise floor: conservative).
    See :func:`quality_thresholds` for the conversion to dB and SSIM.
    """
    n = max(int(n), 1)
    sq = math.sqrt(n)
    if same_reference:
        s = max(sigma_b, sigma_r)
        return 2.0 * z * s * (rmse_b + rmse_r) / sq
    return (max(sigma_r ** 2 - sigma_b ** 2, 0.0)
            + 2.0 * z * (sigma_b * rmse_b + sigma_r * rmse_r) / sq
            + z * math.sqrt(2.0 / n) * (sigma_b ** 2 + sigma_r ** 2))


def quality_thresholds(brow, rrow, th: Thresholds) -> dict:
    """Allowed PSNR and SSIM drops of RUN against BASELINE.

    PSNR = 10 log10(D^2 / m), so an MSE increase of at most ``B`` (:func:`noise_bound`) lowers PSNR by
    at most::

        noise_db = 10 log10(1 + B / m_base)          (m_base from the baseline's PSNR and data range)

    and the PSNR check fails when ``psnr_run < psnr_base - max(tol_db, noise_db)``.

    SSIM: for small errors ``1 - SSIM`` is, to first order, a weighted local squared error — the
    luminance term is ``1 - l = (mu_x - mu_y)^2 / (mu_x^2 + mu_y^2 + C1)`` and the contrast-structure
    term is ``1 - cs = var_local(x - y) / (sigma_x^2 + sigma_y^2 + C2)``, with weights set by the
    reference's local statistics. A perturbation that raises the MSE by the fraction ``B / m_base``
    therefore raises ``1 - SSIM`` by about the same fraction::

        noise_ssim = (1 - ssim_base) B / m_base

    and the SSIM check fails when ``ssim_run < ssim_base - max(ssim_tol, noise_ssim)``.

    Returns ``{"noise_db", "noise_ssim", "B", "m_base", "same_reference", "noise_known"}``.
    """
    sb, kb = _ref_noise(brow)
    sr, kr = _ref_noise(rrow)
    pb, pr = row_value(brow, "psnr"), row_value(rrow, "psnr")
    db, dr = _data_range(brow), _data_range(rrow)
    mb = mse_from_psnr(float(pb), db) if pb is not None and not math.isnan(float(pb)) else math.nan
    mr = mse_from_psnr(float(pr), dr) if pr is not None and not math.isnan(float(pr)) else math.nan
    same = (row_value(brow, "ref_key") is not None and row_value(brow, "ref_key") == row_value(rrow, "ref_key")
            and abs(sb - sr) <= 1e-12 * max(sb, sr, 1e-30))
    n = min(_valid_pixels(brow), _valid_pixels(rrow))
    if math.isnan(mb) or math.isnan(mr):
        B = math.nan
    else:
        B = noise_bound(sigma_b=sb, sigma_r=sr, rmse_b=math.sqrt(mb), rmse_r=math.sqrt(mr), n=n,
                        same_reference=same, z=th.noise_z)
    if math.isnan(B):
        noise_db = noise_ssim = 0.0
    elif mb > 0:
        noise_db = 10.0 * math.log10(1.0 + B / mb)
        sb_ssim = row_value(brow, "ssim")
        noise_ssim = ((1.0 - float(sb_ssim)) * B / mb
                      if sb_ssim is not None and math.isfinite(float(sb_ssim)) else 0.0)
    else:  # a perfect baseline: any error beyond B is a regression
        noise_db = 0.0 if B == 0 else math.inf
        noise_ssim = 0.0
    return {"noise_db": noise_db, "noise_ssim": noise_ssim, "B": B, "m_base": mb, "m_run": mr,
            "same_reference": same, "noise_known": kb and kr}


def psnr_check(pb, pr, q, th):
    if pb is None or math.isnan(pb):
        return "n/a", "", 0.0
    if pr is None or math.isnan(pr):
        return "regression", "NaN", 0.0
    allowed = max(th.tol_db, q["noise_db"])
    if math.isinf(pb) and math.isinf(pr):
        return "ok", "±0.00 dB (both exact)", allowed
    if math.isinf(pb):  # perfect baseline: compare MSE against the noise bound
        verdict = "regression" if not (q["m_run"] <= q["B"]) else "ok"
        return verdict, f"−∞ dB (MSE {q['m_run']:.3g}, bound {q['B']:.3g})", allowed
    drop = pb - pr
    verdict = "regression" if drop > allowed else ("improved" if -drop > allowed else "ok")
    ch = "±0.00" if abs(drop) < 0.005 else f"{-drop:+.2f}"
    return verdict, f"{ch} dB (limit -{allowed:.2f})", allowed


def ssim_check(sb, sr, q, th):
    if sb is None or math.isnan(sb):
        return "n/a", "", 0.0
    if sr is None or math.isnan(sr):
        return "regression", "NaN", 0.0
    allowed = max(th.ssim_tol, q["noise_ssim"])
    drop = sb - sr
    verdict = "regression" if drop > allowed else ("improved" if -drop > allowed else "ok")
    ch = "±0.0000" if abs(drop) < 0.00005 else f"{-drop:+.4f}"
    return verdict, f"{ch} (limit -{allowed:.4f})", allowed



def metric_check(name, brow, rrow, col, better, abs_tol, rel_tol) -> Check:
    """One gated metric of a non-image effect: worse by more than max(abs_tol, rel_tol·|base|) fails."""
    b, r = as_float(row_value(brow, col)), as_float(row_value(rrow, col))
    fmt = lambda v: "NaN" if v is None or math.isnan(v) else f"{v:.4g}"  # noqa: E731
    if b is None or math.isnan(b):
        return Check(name, col, fmt(b), fmt(r), "", "n/a")
    if r is None or math.isnan(r):
        return Check(name, col, fmt(b), fmt(r), "NaN", "regression")
    allowed = max(abs_tol, rel_tol * abs(b))
    worse = (b - r) if better == "higher" else (r - b)
    verdict = "regression" if worse > allowed else ("improved" if -worse > allowed else "ok")
    return Check(name, col, fmt(b), fmt(r), f"{r - b:+.3g} (limit {allowed:.3g})", verdict)
