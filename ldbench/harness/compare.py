"""``ldbench compare BASELINE RUN``: the regression gate of the nightly benchmark (docs/nightly.md).

Both arguments are run directories (``results.parquet``, else ``results.csv``) or results files.
Rows are matched by :data:`DEFAULT_MATCH` (scene and its builder parameters, method, effect and its
parameters, method parameters, image size) or by the keys given with ``--match`` (e.g.
``--match scene,method,effect`` compares two *configurations* of the same method, such as 64 against
16 LDM directions). A match key that leaves two rows of one run indistinguishable is bad input. Method
parameters are matched in their canonical form (:func:`canonical_params`: old names mapped through the
adapter's ``Params.renamed``, values equal to the current default dropped), so a parameter added with a
default orphans no baseline row; a parameter the adapter no longer has keeps its row apart (``missing``).

Every matched benchmark gets up to three checks:

time (``total_ms``)
    One-sided Mann-Whitney U test (:func:`scipy.stats.mannwhitneyu`, ``alternative="greater"``) of
    the run's raw per-frame samples (``raw_ms["total"]``, else ``raw_ms["wall"]``) against the
    baseline's: *is the run stochastically slower?* A regression needs **both** ``p < alpha``
    (default 0.01) **and** a median slow-down of at least ``min_effect`` (default 10 %), so that
    tiny but consistent shifts and noise do not fail the build. The exact test cannot reach
    ``p < alpha`` with too few frames (smallest one-sided p is ``1 / C(n+m, n)``: 5 + 5 frames give
    0.004, 4 + 4 give 0.014); such a check is reported ``inconclusive`` and never fails. A
    significant speed-up of at least ``min_effect`` is reported ``improved``.
    When the machines differ (``device``, ``gl_renderer``, ``driver`` or ``gpu_name``, and ``cpu`` when
    the device is the CPU; :func:`ldbench.core.device.timing_fields`) times are not comparable: a warning
    is printed and time checks are skipped; quality is still gated.
    On a software rasterizer (``device = cpu-software``, Mesa llvmpipe) time checks are skipped as
    well unless ``--cpu-time``: its frame times are wall clock on shared CPU cores, which move between
    identical runs far beyond the within-run spread the test sees (measured in docs/nightly.md); the
    CPU nightly gates quality, the GPU nightly gates time.

quality (``psnr``, ``ssim``)
    A regression is a drop beyond ``max(tolerance, what the references' own Monte Carlo noise can
    explain)``; see :func:`noise_bound` for the derivation. PSNR tolerance ``--tol-db`` (0.5 dB),
    SSIM tolerance ``--ssim-tol`` (0.01). A NaN in the run where the baseline was finite (a broken
    shader) is a regression. A NaN in the baseline (a broken baseline) compares nothing: the check is
    ``unchecked`` and fails, with a warning, unless ``--allow-nan-baseline``.

metrics of non-image effects (``rays``, ...)
    The effect spec's ``gate`` (:class:`ldbench.core.effects.base.EffectSpec`): each listed column may
    get worse by at most ``max(absolute, relative × |baseline|)``; both sides are exact (an oracle, no
    sampling noise), so the tolerances are fixed. A NaN where the baseline was finite is a regression; a
    NaN baseline is ``unchecked`` (as for images) where the run has a value or where no metric of the
    benchmark could be compared; NaN on both sides is a metric the configuration leaves undefined
    (``n/a``: the distances of shadow rays).

status
    A row whose ``status`` is ``degraded: …`` in RUN (an invariant of its data structure failed: nodes
    lost, lists unsorted, overflow) is a regression (``degraded``), as is any other status but
    ``"ok"`` (``failed``). A row of BASELINE that
    RUN lacks is ``missing`` and fails unless ``--allow-missing``; a row only in RUN is ``new`` (never
    fails). A baseline row that had failed is not compared (``fixed`` if RUN's is ok).

Exit status: 0 no regression, 1 regression, 2 bad input (:class:`~ldbench.core.errors.LdbenchError`).
A Markdown report (``compare.md`` in RUN's directory, or ``--md FILE``) holds one table row per
check: benchmark, metric, baseline, current, change, verdict, for a CI job summary. ``--json FILE``
writes the same verdicts for machines (:func:`to_json`): per check the benchmark's match key, the
metric, baseline and current values as numbers, the verdict and the thresholds it was judged by, and
the overall exit status.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

from ldbench.core.device import timing_fields
from ldbench.core.errors import LdbenchError

#: Default match keys: one benchmark = one scene (with builder parameters), method, effect (with its
#: parameters), method parameters and image size.
DEFAULT_MATCH = ("scene", "scene_params", "method", "effect", "effect_params", "params", "width", "height")
#: Every column ``--match`` accepts.
MATCH_KEYS = DEFAULT_MATCH + ("suite", "scene_hash", "ref_spp")

REGRESSING_VERDICTS = ("regression", "failed", "missing", "degraded", "unchecked")


@dataclass
class Thresholds:
    """Gate settings (the CLI flags of the same names)."""

    alpha: float = 0.01        # significance of the one-sided Mann-Whitney U test
    min_effect: float = 0.10   # minimum relative slow-down of the median to count
    tol_db: float = 0.5        # PSNR drop always tolerated (dB)
    ssim_tol: float = 0.01     # SSIM drop always tolerated
    noise_z: float = 3.0       # standard deviations of reference noise tolerated (see noise_bound)
    allow_missing: bool = False
    time: bool = True          # False: skip time checks (--no-time)
    cpu_time: bool = False     # True: gate time on cpu-software (llvmpipe) too (--cpu-time)
    allow_nan_baseline: bool = False  # True: a NaN quality metric of the baseline does not fail

    def validate(self):
        if not 0 < self.alpha < 1:
            raise LdbenchError(f"--alpha must be in (0, 1), got {self.alpha}")
        for name in ("min_effect", "tol_db", "ssim_tol", "noise_z"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise LdbenchError(f"--{name.replace('_', '-')} must be a finite number >= 0, got {v}")
        return self


@dataclass
class Check:
    benchmark: str
    metric: str            # "time", "psnr", "ssim", "status"
    baseline: str
    current: str
    change: str
    verdict: str           # ok | regression | improved | inconclusive | skipped | failed | missing | new | fixed
    #                        | unchecked (the baseline's metric is NaN: nothing to compare against) | n/a
    note: str = ""

    @property
    def regression(self) -> bool:
        return self.verdict in REGRESSING_VERDICTS


@dataclass
class Comparison:
    checks: list = field(default_factory=list)
    warnings: list = field(default_factory=list)
    notes: list = field(default_factory=list)    # per-benchmark remarks (differing configurations, ...)
    match: tuple = DEFAULT_MATCH
    thresholds: Thresholds = field(default_factory=Thresholds)
    baseline_label: str = ""
    run_label: str = ""
    matched: int = 0
    rows: dict = field(default_factory=dict)  # benchmark label -> (baseline row, run row), for to_json

    @property
    def regressions(self) -> list:
        return [c for c in self.checks if c.regression]

    @property
    def exit_code(self) -> int:
        return 1 if self.regressions else 0

    def count(self, verdict: str) -> int:
        return sum(c.verdict == verdict for c in self.checks)


# --------------------------------------------------------------------------------------------------
# input


#: Columns the gate reads besides the match keys; a table without one of them cannot be gated (a missing
#: ``psnr`` would otherwise pass every quality check as "n/a").
REQUIRED_COLUMNS = ("status", "total_ms", "raw_ms", "psnr", "ssim")


def check_schema(df, what: str, path, match=DEFAULT_MATCH) -> None:
    """Refuse a results table without a column the comparison needs (LdbenchError naming it)."""
    from .records import check_columns

    check_columns(df.columns, f"{what} {path}", (*match, *REQUIRED_COLUMNS))


def load_results(path, what: str = "results", match=DEFAULT_MATCH):
    """Results of a run directory or results file as a DataFrame (see :func:`records.read_results`).

    Raises :class:`LdbenchError` for a missing path, a directory without results, an empty table, or
    a table without the columns of ``match`` and :data:`REQUIRED_COLUMNS`.
    """
    from .records import read_results

    p = Path(path)
    if not p.exists():
        raise LdbenchError(f"{what} not found: {path}")
    df = read_results(p)
    check_schema(df, what, path, match)
    if len(df) == 0:
        raise LdbenchError(f"{what} {path} holds no result rows")
    return df


def parse_match(text: str | None) -> tuple:
    """``"scene,method,effect"`` -> tuple of keys; None/empty -> :data:`DEFAULT_MATCH`."""
    if text is None or not text.strip():
        return DEFAULT_MATCH
    keys = tuple(k.strip() for k in text.split(",") if k.strip())
    for k in keys:
        if k not in MATCH_KEYS:
            raise LdbenchError(f"unknown match key {k!r} (known: {', '.join(MATCH_KEYS)})")
    if len(set(keys)) != len(keys):
        raise LdbenchError(f"match key given twice in {text!r}")
    return keys


def _missing(v) -> bool:
    if v is None:
        return True
    if isinstance(v, (dict, list, tuple, str)):
        return False
    import pandas as pd

    r = pd.isna(v)  # NaN, pd.NA, NaT
    return bool(r) if isinstance(r, bool) or type(r).__name__ == "bool_" else False


def _plain(v):
    """Python scalar / container for JSON (numpy and pandas scalars unwrapped)."""
    if _missing(v):
        return None
    if hasattr(v, "item") and not isinstance(v, (dict, list, str)):
        try:
            return v.item()
        except (ValueError, AttributeError):
            pass
    return v


def canonical(v) -> str:
    v = _plain(v)
    if isinstance(v, float) and v.is_integer():
        v = int(v)
    return json.dumps(v, sort_keys=True, default=str)


#: Columns holding JSON that :func:`records.read_results` may leave as text (extra columns).
_JSON_TEXT = ("scene_params",)


def row_value(row, col):
    v = _plain(row[col]) if col in row.index else None
    if col in _JSON_TEXT and isinstance(v, str):
        try:
            v = json.loads(v)
        except ValueError:
            pass
    return v


def row_key(row, keys) -> tuple:
    out = []
    for k in keys:
        if k == "scene_params":
            out.append(canonical(row_value(row, k) or {}))
        elif k == "method":  # an adapter's earlier name (e.g. ldm-ao) matches its current one
            from ldbench.methods.base import canonical_name
            out.append(canonical(canonical_name(str(row_value(row, k)))))
        elif k == "params":  # defaults dropped, old names mapped: a new parameter orphans no baseline row
            out.append(canonical(canonical_params(row_value(row, "method"), row_value(row, k) or {})))
        else:
            out.append(canonical(row_value(row, k)))
    return tuple(out)


def canonical_params(method, params: dict) -> dict:
    """``params`` as the match key sees them: names mapped through the adapter's ``Params.renamed`` (old flat
    name -> current name) and every value equal to the adapter's current default dropped, so that a row
    recorded before a parameter was added (or renamed) matches a row recorded after. A parameter the
    adapter no longer has stays (the configuration no longer exists: the row is reported missing). An
    unknown method's parameters are returned as given."""
    from ldbench.methods.base import get_method

    if not isinstance(params, dict):
        return params
    try:
        cls = get_method(str(method))
        defaults = cls.Params().to_dict()
    except (LdbenchError, TypeError):
        return params
    renamed = getattr(cls.Params, "renamed", None) or {}
    out = {}
    for name, value in params.items():
        name = renamed.get(name, name)
        if name in defaults and canonical(value) == canonical(defaults[name]):
            continue
        out[name] = value
    return out


def _index(df, keys, what) -> dict:
    idx = {}
    for _, row in df.iterrows():
        k = row_key(row, keys)
        if k in idx:
            raise LdbenchError(
                f"{what} has several rows for {_describe_key(keys, k)}; add keys to --match "
                f"(known: {', '.join(MATCH_KEYS)})")
        idx[k] = row
    return idx


def _describe_key(keys, k) -> str:
    return ", ".join(f"{n}={json.loads(v)!r}" for n, v in zip(keys, k))


def _fmt_params(d: dict) -> str:
    return " ".join(f"{k}={_fmt_value(v)}" for k, v in sorted(d.items()))


def _fmt_value(v):
    if isinstance(v, float):
        return f"{v:g}"
    return str(v)


def _effect_label(row) -> str:
    from ldbench.reports.labels import effect_text

    return effect_text(row_value(row, "effect") or "?", row_value(row, "effect_params") or {})


def benchmark_labels(rows_by_key: dict) -> dict:
    """Readable benchmark names: scene[params] · method · effect · WxH, plus the method parameters that
    differ between benchmarks of the same scene, method and effect."""
    groups: dict = {}
    for k, row in rows_by_key.items():
        g = (row_value(row, "scene"), row_value(row, "method"), row_value(row, "effect"))
        groups.setdefault(g, []).append(k)
    labels = {}
    for g, ks in groups.items():
        varying = set()
        if len(ks) > 1:
            dicts = [(row_value(rows_by_key[k], "params") or {}) for k in ks]
            names = set().union(*[set(d) for d in dicts])
            varying = {n for n in names if len({canonical(d.get(n)) for d in dicts}) > 1}
        for k in ks:
            row = rows_by_key[k]
            sp = row_value(row, "scene_params") or {}
            scene = f"{row_value(row, 'scene')}" + (f"[{_fmt_params(sp)}]" if sp else "")
            parts = [scene, row_value(row, "method"), _effect_label(row)]
            w, h = row_value(row, "width"), row_value(row, "height")
            if w is not None and h is not None:
                parts.append(f"{w}x{h}")
            p = row_value(row, "params") or {}
            if varying:
                parts.append(_fmt_params({n: p.get(n) for n in sorted(varying)}))
            labels[k] = " · ".join(str(x) for x in parts)
    # Distinct keys whose readable names collide (e.g. other effect params): disambiguate.
    seen: dict = {}
    for k, lab in labels.items():
        seen.setdefault(lab, []).append(k)
    for lab, ks in seen.items():
        if len(ks) > 1:
            for i, k in enumerate(sorted(ks)):
                labels[k] = f"{lab} #{i + 1}"
    return labels


def _config_diff(brow, rrow) -> str:
    """Differences between two matched rows outside the match keys (params, size, reference)."""
    diffs = []
    bp, rp = row_value(brow, "params") or {}, row_value(rrow, "params") or {}
    cb, cr = canonical_params(row_value(brow, "method"), bp), canonical_params(row_value(rrow, "method"), rp)
    shown = lambda c, n: _fmt_value(c[n]) if n in c else "default"  # noqa: E731
    for n in sorted(set(cb) | set(cr)):  # a parameter left at its default is no difference
        if canonical(cb.get(n)) != canonical(cr.get(n)):
            diffs.append(f"{n} {shown(cb, n)} → {shown(cr, n)}")
    for col in ("width", "height", "effect_params", "scene_params", "scene_hash", "triangles", "ref_spp"):
        if canonical(row_value(brow, col)) != canonical(row_value(rrow, col)):
            diffs.append(f"{col} {row_value(brow, col)} → {row_value(rrow, col)}")
    return ", ".join(diffs)


# --------------------------------------------------------------------------------------------------
# time


def _samples(row) -> list:
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
    import numpy as np
    from scipy.stats import mannwhitneyu

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


def machine_diff(brow, rrow) -> list:
    """``[(field, baseline value, run value)]`` for the machine fields that differ
    (:func:`ldbench.core.device.timing_fields`: the CPU too where it is the device)."""
    out = []
    for f in timing_fields(row_value(brow, "device"), row_value(rrow, "device")):
        bv, rv = row_value(brow, f), row_value(rrow, f)
        if (bv or None) != (rv or None):
            out.append((f, bv, rv))
    return out


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
    d = (_settings(row).get("psnr") or {}).get("data_range")
    try:
        d = float(d)
    except (TypeError, ValueError):
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


def _psnr_check(pb, pr, q, th):
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


def _ssim_check(sb, sr, q, th):
    if sb is None or math.isnan(sb):
        return "n/a", "", 0.0
    if sr is None or math.isnan(sr):
        return "regression", "NaN", 0.0
    allowed = max(th.ssim_tol, q["noise_ssim"])
    drop = sb - sr
    verdict = "regression" if drop > allowed else ("improved" if -drop > allowed else "ok")
    ch = "±0.0000" if abs(drop) < 0.00005 else f"{-drop:+.4f}"
    return verdict, f"{ch} (limit -{allowed:.4f})", allowed


# --------------------------------------------------------------------------------------------------
# comparison


def _f(v) -> float | None:
    v = _plain(v)
    return None if v is None else float(v)


def _fmt_ms(v):
    return "—" if v is None or math.isnan(v) else f"{v:.4g} ms"


def compare_frames(base, run, *, match=DEFAULT_MATCH, thresholds: Thresholds | None = None) -> Comparison:
    """Compare two results DataFrames (as from :func:`records.read_results`); see the module docstring."""
    th = (thresholds or Thresholds()).validate()
    match = tuple(match)
    for k in match:
        if k not in MATCH_KEYS:
            raise LdbenchError(f"unknown match key {k!r} (known: {', '.join(MATCH_KEYS)})")
    bidx = _index(base, match, "baseline")
    ridx = _index(run, match, "run")
    union = {**{k: v for k, v in ridx.items()}, **{k: v for k, v in bidx.items() if k not in ridx}}
    labels = benchmark_labels(union)
    comp = Comparison(match=match, thresholds=th)
    comp.rows = {labels[k]: (bidx.get(k), ridx.get(k)) for k in union}
    machine_warned = set()
    nan_base: list = []  # benchmarks whose baseline has a NaN quality metric

    order = list(bidx) + [k for k in ridx if k not in bidx]
    for k in order:
        name = labels[k]
        brow, rrow = bidx.get(k), ridx.get(k)
        if rrow is None:
            comp.checks.append(Check(name, "status", str(row_value(brow, "status")), "—", "row vanished",
                                     "missing" if not th.allow_missing else "n/a",
                                     "allowed by --allow-missing" if th.allow_missing else ""))
            continue
        if brow is None:
            comp.checks.append(Check(name, "status", "—", str(row_value(rrow, "status")), "new row", "new"))
            continue
        comp.matched += 1
        diff = _config_diff(brow, rrow)
        if diff:
            comp.notes.append(f"{name}: {diff}")
        bstat, rstat = str(row_value(brow, "status") or "?"), str(row_value(rrow, "status") or "?")
        if rstat != "ok":
            comp.checks.append(Check(name, "status", bstat, rstat, "",
                                     "degraded" if rstat.startswith("degraded") else "failed"))
            continue
        if bstat != "ok":
            comp.checks.append(Check(name, "status", bstat, rstat, "baseline had failed", "fixed"))
            continue

        # time
        md = machine_diff(brow, rrow)
        tb, tr = _f(row_value(brow, "total_ms")), _f(row_value(rrow, "total_ms"))
        if not th.time:
            comp.checks.append(Check(name, "time", _fmt_ms(tb), _fmt_ms(tr), "", "skipped", "--no-time"))
        elif (not th.cpu_time and row_value(brow, "device") == "cpu-software"
              and row_value(rrow, "device") == "cpu-software"):
            if "cpu" not in machine_warned:
                machine_warned.add("cpu")
                comp.warnings.append("software rasterizer (cpu-software): frame times are wall clock on "
                                     "shared CPU cores and vary between runs far more than within a run; "
                                     "time checks are off (--cpu-time turns them on), quality is gated")
            comp.checks.append(Check(name, "time", _fmt_ms(tb), _fmt_ms(tr), "", "skipped", "cpu-software"))
        elif md:
            sig = tuple(md)
            if sig not in machine_warned:
                machine_warned.add(sig)
                comp.warnings.append("machine differs (" + "; ".join(
                    f"{f}: {bv!r} → {rv!r}" for f, bv, rv in md) + "): time checks are off, quality is "
                    "still gated")
            comp.checks.append(Check(name, "time", _fmt_ms(tb), _fmt_ms(tr), "", "skipped",
                                     "machine differs"))
        else:
            t = time_check(_samples(brow), _samples(rrow), th)
            if t["verdict"] in ("n/a", "inconclusive"):
                change = "" if math.isnan(t["change"]) else f"{t['change']:+.1%}"
            else:
                p = t["p"] if t["verdict"] != "improved" else t["p_faster"]
                change = f"{t['change']:+.1%} (p={p:.2g})"
            comp.checks.append(Check(name, "time", _fmt_ms(tb), _fmt_ms(tr), change, t["verdict"], t["note"]))

        # quality
        gate = gated_metrics(rrow)
        if gate:
            checks = [metric_check(name, brow, rrow, *g) for g in gate]
            compared = any(c.verdict != "n/a" for c in checks)
            for i, c in enumerate(checks):  # a NaN baseline judges nothing: say so (both NaN: undefined here)
                if c.baseline == "NaN" and (c.current != "NaN" or not compared):
                    checks[i] = _nan_baseline(name, c.metric, c.current, th)
                    nan_base += [name] if name not in nan_base else []
            comp.checks += checks
            continue
        q = quality_thresholds(brow, rrow, th)
        pb, pr = _f(row_value(brow, "psnr")), _f(row_value(rrow, "psnr"))
        sb, sr = _f(row_value(brow, "ssim")), _f(row_value(rrow, "ssim"))
        if pb is None or math.isnan(pb) or sb is None or math.isnan(sb):
            nan_base.append(name)
        if pb is None or math.isnan(pb):
            comp.checks.append(_nan_baseline(name, "psnr", _fmt_db(pr), th))
        v, change, _ = _psnr_check(pb, pr, q, th)
        if v != "n/a":
            notes = [] if q["noise_known"] else ["reference noise unknown"]
            if row_value(brow, "scene_hash") != row_value(rrow, "scene_hash"):
                notes.append("scene differs")
            elif not q["same_reference"]:
                notes.append("references differ")
            note = "; ".join(notes)
            comp.checks.append(Check(name, "psnr", _fmt_db(pb), _fmt_db(pr), change, v, note))
        if sb is None or math.isnan(sb):
            comp.checks.append(_nan_baseline(name, "ssim", _fmt_num(sr), th))
        v, change, _ = _ssim_check(sb, sr, q, th)
        if v != "n/a":
            comp.checks.append(Check(name, "ssim", _fmt_num(sb), _fmt_num(sr), change, v))
    if nan_base:
        comp.warnings.append(
            f"the baseline has NaN quality metrics for {len(nan_base)} benchmark(s) ({nan_base[0]}"
            + (", ..." if len(nan_base) > 1 else "") + "): nothing to compare them against; "
            + ("allowed by --allow-nan-baseline" if th.allow_nan_baseline
               else "they fail unless --allow-nan-baseline"))
    return comp


def _nan_baseline(name, metric, current, th) -> Check:
    """The check of a metric the baseline holds as NaN (a broken baseline): ``unchecked`` (failing), or
    ``n/a`` with ``--allow-nan-baseline``."""
    if th.allow_nan_baseline:
        return Check(name, metric, "NaN", current, "", "n/a", "baseline NaN, allowed by --allow-nan-baseline")
    return Check(name, metric, "NaN", current, "baseline NaN", "unchecked", "nothing to compare against")


def gated_metrics(row) -> tuple:
    """The effect's gated metrics (non-image effects), () for image effects and unknown effects."""
    from ldbench.core.effects import registry

    spec = registry().get(str(row_value(row, "effect")))
    return tuple(spec.gate) if spec is not None else ()


def metric_check(name, brow, rrow, col, better, abs_tol, rel_tol) -> Check:
    """One gated metric of a non-image effect: worse by more than max(abs_tol, rel_tol·|base|) fails."""
    b, r = _f(row_value(brow, col)), _f(row_value(rrow, col))
    fmt = lambda v: "NaN" if v is None or math.isnan(v) else f"{v:.4g}"  # noqa: E731
    if b is None or math.isnan(b):
        return Check(name, col, fmt(b), fmt(r), "", "n/a")
    if r is None or math.isnan(r):
        return Check(name, col, fmt(b), fmt(r), "NaN", "regression")
    allowed = max(abs_tol, rel_tol * abs(b))
    worse = (b - r) if better == "higher" else (r - b)
    verdict = "regression" if worse > allowed else ("improved" if -worse > allowed else "ok")
    return Check(name, col, fmt(b), fmt(r), f"{r - b:+.3g} (limit {allowed:.3g})", verdict)


def _fmt_db(v):
    if v is None or math.isnan(v):
        return "NaN"
    return "∞ dB" if math.isinf(v) else f"{v:.2f} dB"


def _fmt_num(v):
    return "NaN" if v is None or math.isnan(v) else f"{v:.4f}"


def _run_label(df, path) -> str:
    ids = sorted({str(x) for x in df["run_id"].dropna()}) if "run_id" in df else []
    commits = sorted({str(x)[:10] for x in df["commit"].dropna()}) if "commit" in df else []
    dirty = bool(df["dirty"].fillna(False).any()) if "dirty" in df else False
    parts = [f"`{path}`"]
    if ids:
        parts.append(f"run {', '.join(ids)}")
    if commits:
        parts.append(f"commit {', '.join(commits)}" + (" (dirty)" if dirty else ""))
    return ", ".join(parts)


_ICON = {"regression": "❌ regression", "failed": "❌ failed", "missing": "❌ missing", "ok": "✅ ok",
         "degraded": "❌ degraded", "unchecked": "❌ unchecked",
         "improved": "🟢 improved", "new": "🆕 new", "fixed": "🟢 fixed", "skipped": "⏭ skipped",
         "inconclusive": "❔ inconclusive", "n/a": "n/a"}


def _md_cell(s) -> str:
    return str(s).replace("|", "\\|").replace("\n", " ")


def to_markdown(comp: Comparison) -> str:
    """The Markdown report: header, warnings, the table, notes."""
    th = comp.thresholds
    n_reg = len(comp.regressions)
    head = "❌ **regression**" if n_reg else "✅ **no regression**"
    lines = [f"## ldbench compare: {head}", "",
             f"- baseline: {comp.baseline_label}", f"- current: {comp.run_label}",
             f"- matched by: {', '.join(comp.match)}; {comp.matched} benchmark(s) matched, "
             f"{comp.count('missing')} missing, {comp.count('new')} new; "
             f"{n_reg} failing check(s)",
             f"- gate: time = one-sided Mann-Whitney U p < {th.alpha:g} and slow-down ≥ {th.min_effect:.0%}; "
             f"PSNR drop > max({th.tol_db:g} dB, reference noise); SSIM drop > max({th.ssim_tol:g}, "
             f"reference noise); reference noise at {th.noise_z:g} σ"
             + ("" if th.time else "; time checks off (--no-time)"), ""]
    for w in comp.warnings:
        lines.append(f"> ⚠️ **warning:** {w}")
    if comp.warnings:
        lines.append("")
    lines += ["| benchmark | metric | baseline | current | change | verdict |",
              "|---|---|---|---|---|---|"]
    for c in comp.checks:
        verdict = _ICON.get(c.verdict, c.verdict) + (f" ({c.note})" if c.note else "")
        lines.append("| " + " | ".join(_md_cell(x) for x in (c.benchmark, c.metric, c.baseline, c.current,
                                                               c.change, verdict)) + " |")
    if comp.notes:
        lines += ["", "Configurations that differ between matched rows:", ""]
        lines += [f"- {_md_cell(n)}" for n in comp.notes]
    return "\n".join(lines) + "\n"


#: Format of :func:`to_json`'s document; bumped when a field is removed or changes meaning.
JSON_FORMAT = "ldbench-compare/1"

#: The column a check's metric reads (gated metrics of non-image effects are their own column).
_METRIC_COLUMN = {"time": "total_ms", "status": "status"}


def _json_value(v):
    """A value as strict JSON: NaN -> None, ±inf -> "inf"/"-inf", numpy/pandas scalars unwrapped."""
    v = _plain(v)
    if isinstance(v, float) and not math.isfinite(v):
        return None if math.isnan(v) else ("inf" if v > 0 else "-inf")
    if isinstance(v, dict):
        return {str(k): _json_value(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_json_value(x) for x in v]
    return v


def _check_thresholds(c: Check, brow, rrow, th: Thresholds) -> dict:
    """The thresholds a check was judged by (recomputed from the rows, as :func:`compare_frames` does)."""
    if c.metric == "status":
        return {"allow_missing": th.allow_missing} if c.verdict in ("missing", "n/a") else {}
    if c.metric == "time":
        return {"alpha": th.alpha, "min_effect": th.min_effect, "time": th.time, "cpu_time": th.cpu_time}
    if brow is None or rrow is None:
        return {}
    if c.metric in ("psnr", "ssim"):
        q = quality_thresholds(brow, rrow, th)
        if c.metric == "psnr":
            return {"tol_db": th.tol_db, "noise_z": th.noise_z, "noise_db": q["noise_db"],
                    "allowed_drop_db": max(th.tol_db, q["noise_db"])}
        return {"ssim_tol": th.ssim_tol, "noise_z": th.noise_z, "noise_ssim": q["noise_ssim"],
                "allowed_drop": max(th.ssim_tol, q["noise_ssim"])}
    for col, better, abs_tol, rel_tol in gated_metrics(rrow):
        if col == c.metric:
            b = _f(row_value(brow, col))
            allowed = max(abs_tol, rel_tol * abs(b)) if b is not None and math.isfinite(b) else None
            return {"better": better, "abs_tol": abs_tol, "rel_tol": rel_tol, "allowed_change": allowed}
    return {}


def to_json(comp: Comparison) -> dict:
    """The comparison as a JSON-able dict (``--json``), strict JSON (no NaN: see :func:`_json_value`).

    ``{"format", "exit_status", "regression", "baseline", "current", "match", "matched", "counts",
    "thresholds", "warnings", "notes", "checks": [{"benchmark", "key", "metric", "column", "baseline",
    "current", "baseline_text", "current_text", "change", "verdict", "regression", "note",
    "thresholds"}]}``. ``key`` holds the match keys' values of the benchmark; ``baseline`` and
    ``current`` the column's values (None where a side is missing), ``*_text`` and ``change`` what the
    Markdown table shows.
    """
    import dataclasses

    checks = []
    for c in comp.checks:
        brow, rrow = comp.rows.get(c.benchmark, (None, None))
        row = rrow if rrow is not None else brow
        col = _METRIC_COLUMN.get(c.metric, c.metric)
        checks.append({
            "benchmark": c.benchmark,
            "key": {k: _json_value(row_value(row, k)) for k in comp.match} if row is not None else {},
            "metric": c.metric, "column": col,
            "baseline": _json_value(row_value(brow, col)) if brow is not None else None,
            "current": _json_value(row_value(rrow, col)) if rrow is not None else None,
            "baseline_text": c.baseline, "current_text": c.current, "change": c.change,
            "verdict": c.verdict, "regression": c.regression, "note": c.note,
            "thresholds": _json_value(_check_thresholds(c, brow, rrow, comp.thresholds)),
        })
    counts: dict = {}
    for c in comp.checks:
        counts[c.verdict] = counts.get(c.verdict, 0) + 1
    return {"format": JSON_FORMAT, "exit_status": comp.exit_code, "regression": bool(comp.regressions),
            "baseline": comp.baseline_label, "current": comp.run_label, "match": list(comp.match),
            "matched": comp.matched, "counts": counts,
            "thresholds": _json_value(dataclasses.asdict(comp.thresholds)),
            "warnings": list(comp.warnings), "notes": list(comp.notes), "checks": checks}


def summary_text(comp: Comparison) -> str:
    """A few lines for the terminal."""
    n_reg = len(comp.regressions)
    out = [f"compare: {comp.matched} matched, {comp.count('missing')} missing, {comp.count('new')} new, "
           f"{len(comp.checks)} checks: " + (f"{n_reg} REGRESSION(S)" if n_reg else "no regression")]
    for c in comp.regressions:
        out.append(f"  {c.verdict.upper():<10} {c.benchmark} [{c.metric}] {c.baseline} → {c.current} "
                   f"{c.change}".rstrip() + (f" ({c.note})" if c.note else ""))
    imp = [c for c in comp.checks if c.verdict in ("improved", "fixed")]
    if imp:
        out.append(f"  {len(imp)} improved check(s)")
    return "\n".join(out)


def compare_paths(baseline, run, *, match=DEFAULT_MATCH, thresholds: Thresholds | None = None) -> Comparison:
    """Load two runs (directories or results files) and compare them."""
    base_df = load_results(baseline, "baseline", match)
    run_df = load_results(run, "run", match)
    comp = compare_frames(base_df, run_df, match=match, thresholds=thresholds)
    comp.baseline_label = _run_label(base_df, baseline)
    comp.run_label = _run_label(run_df, run)
    return comp


# --------------------------------------------------------------------------------------------------
# CLI


def add_arguments(p):
    p.add_argument("baseline", help="baseline run directory or results.parquet/.csv")
    p.add_argument("run", help="current run directory or results.parquet/.csv")
    p.add_argument("--match", default=None, metavar="KEYS",
                   help=f"comma-separated match keys (default: {','.join(DEFAULT_MATCH)}; "
                        f"known: {','.join(MATCH_KEYS)})")
    p.add_argument("--alpha", type=float, default=Thresholds.alpha,
                   help="significance of the one-sided Mann-Whitney U test on frame times (default 0.01)")
    p.add_argument("--min-effect", type=float, default=Thresholds.min_effect,
                   help="minimum relative slow-down of the median frame time (default 0.10 = 10%%)")
    p.add_argument("--tol-db", type=float, default=Thresholds.tol_db,
                   help="PSNR drop always tolerated, dB (default 0.5)")
    p.add_argument("--ssim-tol", type=float, default=Thresholds.ssim_tol,
                   help="SSIM drop always tolerated (default 0.01)")
    p.add_argument("--noise-z", type=float, default=Thresholds.noise_z,
                   help="reference-noise bound in standard deviations (default 3)")
    p.add_argument("--allow-missing", action="store_true", help="rows that vanished do not fail")
    p.add_argument("--no-time", action="store_true", help="skip time checks (quality only)")
    p.add_argument("--allow-nan-baseline", action="store_true",
                   help="a quality metric that is NaN in the baseline (nothing to compare against) does not fail")
    p.add_argument("--cpu-time", action="store_true",
                   help="gate time on a software rasterizer (cpu-software) too; off by default")
    p.add_argument("--md", "--out", dest="md", default=None, metavar="FILE",
                   help="write the Markdown report here (default: compare.md in RUN's directory)")
    p.add_argument("--json", dest="json", default=None, metavar="FILE",
                   help="also write the verdicts as JSON for CI: per check the match key, metric, baseline, "
                        "current, verdict and thresholds, and the exit status")


def _ours_md(head: bytes) -> bool:
    return head.startswith(b"## ldbench compare:")


def _ours_json(head: bytes) -> bool:
    return head.lstrip().startswith(b"{") and f'"format": "{JSON_FORMAT}"'.encode() in head


def _write_text(path: Path, text: str, ours):
    """Write ``text`` to ``path`` through a temporary file and a rename (no half-written report); an existing
    file is replaced only where ``ours`` recognises an earlier report of the same kind."""
    from ldbench.core.files import atomic_write_text, check_replaceable

    check_replaceable(path, ours)
    try:
        atomic_write_text(path, text)
    except OSError as e:
        raise LdbenchError(f"cannot write {path}: {e.strerror or e}")


def run_cli(args) -> int:
    th = Thresholds(alpha=args.alpha, min_effect=args.min_effect, tol_db=args.tol_db,
                    ssim_tol=args.ssim_tol, noise_z=args.noise_z, allow_missing=args.allow_missing,
                    time=not args.no_time, cpu_time=args.cpu_time,
                    allow_nan_baseline=args.allow_nan_baseline)
    match = parse_match(args.match)
    comp = compare_paths(args.baseline, args.run, match=match, thresholds=th)
    run_path = Path(args.run)
    out = Path(args.md) if args.md else (run_path if run_path.is_dir() else run_path.parent) / "compare.md"
    from ldbench.core.files import check_replaceable

    check_replaceable(out, _ours_md)  # both outputs checked before either is written
    if args.json:
        check_replaceable(Path(args.json), _ours_json)
    _write_text(out, to_markdown(comp), _ours_md)
    if args.json:
        _write_text(Path(args.json), json.dumps(to_json(comp), indent=2, allow_nan=False) + "\n", _ours_json)
    import logging
    log = logging.getLogger(__name__)
    for w in comp.warnings:
        log.warning(w)
    print(summary_text(comp))
    print(f"wrote {out}" + (f" and {args.json}" if args.json else ""))
    return comp.exit_code
