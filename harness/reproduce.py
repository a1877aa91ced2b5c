"""``ldbench reproduce``: one paper table or figure, our numbers beside the published ones.

The registry :data:`REGISTRY` holds one :class:`Reproduction` per paper table/figure. An entry is data:

* where the numbers come from (paper key, figure/table, the GPU and resolution the paper used),
* the suite that reproduces it (a TOML path relative to the repository root),
* ``rows``: a list of dicts, one per published row (or one per row of ours that a claim needs), each
  with a ``match`` that selects our result row (scene, method, effect, d_max, falloff, params,
  scene_params, size) and the published values under the keys of :data:`QUANTITIES`,
* ``claims``: the paper's statements as comparisons between rows (:class:`Claim`), each with a verdict
  on our numbers: ``holds`` / ``does not hold on this machine`` / ``not measured`` (a row is missing or
  failed) / ``inconclusive`` (two times differ by less than the larger of their interquartile ranges),
* ``scales``: suite overrides for ``--scale ci`` (tiny, for CI on llvmpipe) and ``--scale paper`` (the
  suite as written). A scale's parameter overrides are applied to the rows' ``match`` too, so the same
  rows find their counterparts at every scale.

Adding a table (e.g. niessner2010 Table 1) is a data addition: write its suite TOML, transcribe the rows
and claims into one more :class:`Reproduction` in :data:`REGISTRY`.

Quantities
----------
``time_ms`` ← ``total_ms`` (median frame time; GPU timer queries, or wall clock on a software
rasterizer), ``memory_mb`` ← ``memory_bytes`` / 2**20, ``psnr`` (dB), ``ssim``, ``flip``, ``relmse``.
The ratio column is ours / published: on different hardware (and a stand-in scene) it measures the
machine as much as the method, which is why the verdicts compare rows *within* our run (the paper's
claims are relative statements) and never our absolute numbers with the published ones.
"""
from __future__ import annotations

import dataclasses
import json
import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from .errors import LdbenchError

REPO = Path(__file__).resolve().parent.parent

#: quantity → (our column, unit, higher is better, label)
QUANTITIES = {
    "time_ms": ("total_ms", "ms", False, "time"),
    "memory_mb": ("memory_bytes", "MB", False, "memory"),
    "psnr": ("psnr", "dB", True, "PSNR"),
    "ssim": ("ssim", "", True, "SSIM"),
    "flip": ("flip", "", False, "FLIP"),
    "relmse": ("relmse", "", False, "relMSE"),
}

HOLDS = "holds"
FAILS = "does not hold on this machine"
NOT_MEASURED = "not measured"
INCONCLUSIVE = "inconclusive (difference within the timing noise)"


@dataclass(frozen=True)
class Claim:
    """A statement of the paper as a comparison between two rows (by ``id``).

    ``kind``:

    * ``"less"`` / ``"greater"``: row ``a``'s value is below / above row ``b``'s for every quantity;
    * ``"better"``: ``a`` beats ``b`` on every quantity (lower time/memory/FLIP/relMSE, higher PSNR/SSIM);
    * ``"ratio"``: a / b of the first quantity lies within ``ratio`` = (lo, hi).
    """

    text: str
    a: str
    b: str
    quantities: tuple = ("time_ms",)
    kind: str = "less"
    ratio: tuple | None = None
    where: str = ""  # where the paper says it (figure, section)
    published: str = ""  # the published evidence when not a pair of numbers (e.g. "images only")


@dataclass(frozen=True)
class Reproduction:
    key: str
    paper: str
    title: str
    source: str  # figure / table and section in the paper
    hardware: str  # the paper's GPU
    resolution: str  # the paper's image size
    paper_scene: str
    suite: str  # path relative to the repository root
    rows: tuple  # dicts, see the module docstring
    claims: tuple = ()
    scales: dict = field(default_factory=dict)
    notes: tuple = ()


# --------------------------------------------------------------------------------------------------
# aalund2015: Aalund, Frisvad, Bærentzen, EGSR 2015 (shared/papers/aalund2015.md)
#
# Scene scaling: Crytek Sponza (the paper's scene; 262,267 triangles) spans about 3720.9 × 1555.9 ×
# 2288.2 model units (x ∈ [-1920.9, 1799.9], y ∈ [-126.4, 1429.4], z ∈ [-1182.8, 1105.4]). The paper's
# "d_max = 1280m" is in these model units (the printed "m" cannot be metres: the courtyard would be
# 3.7 km long), i.e. 1280 / 3720.9 = 0.344 of the model's length. Our stand-in `atrium` (260,000
# triangles) is 30 m long (x ∈ [-15, 15]), so d_max = 0.344 · 30 m = 10.32 m.

SPONZA_LENGTH_UNITS = 3720.86
ATRIUM_LENGTH_M = 30.0
FIG8_D_MAX = round(1280.0 * ATRIUM_LENGTH_M / SPONZA_LENGTH_UNITS, 2)  # 10.32 m
SMALL_D_MAX = 0.25  # "as d_max → 0" (§5.1): 0.25 m ≈ 31 Sponza units

_CI_AALUND = {
    "size": "32x32", "spp": 16, "warmup": 1, "frames": 3,
    "params": {"ldm-ao": {"directions": 16, "resolution": {200: 64, 50: 16}},
               "hbao": {"max_radius_px": 64.0}},
    "scene_params": {"atrium": {"triangles": 4000}, "hairball": {"triangles": 2000}},
}

AALUND2015_FIG8 = Reproduction(
    key="aalund2015-fig8",
    paper="aalund2015",
    title="LDM ambient occlusion vs HBAO at large d_max (Figure 8)",
    source="Figure 8 and its caption; §5.1",
    hardware="NVIDIA GeForce GTX 780 Ti",
    resolution="800x800",
    paper_scene="Crytek Sponza (262k triangles)",
    suite="suites/aalund2015-fig8.toml",
    rows=(
        {"id": "ldm", "label": "Fig. 8(a) LDMs",
         "paper_setup": "Crytek Sponza, 512 LDMs of 200×200, d_max = 1280 m (attenuated)",
         "match": {"scene": "atrium", "method": "ldm-ao", "effect": "ao", "d_max": FIG8_D_MAX,
                   "falloff": "quadratic", "params": {"directions": 512, "resolution": 200}},
         "time_ms": 512.4, "memory_mb": 805.5},
        {"id": "hbao", "label": "Fig. 8(c) HBAO",
         "paper_setup": "Crytek Sponza, HBAO, d_max = 1280 m (attenuated)",
         "match": {"scene": "atrium", "method": "hbao", "effect": "ao", "d_max": FIG8_D_MAX,
                   "falloff": "quadratic"},
         "time_ms": 903.6},
        {"id": "ldm-small", "label": "LDMs, small d_max (§5.1 text)",
         "paper_setup": "as (a), d_max → 0 (no numbers published)",
         "match": {"scene": "atrium", "method": "ldm-ao", "effect": "ao", "d_max": SMALL_D_MAX,
                   "falloff": "quadratic", "params": {"directions": 512, "resolution": 200}}},
        {"id": "hbao-small", "label": "HBAO, small d_max (§5.1 text)",
         "paper_setup": "as (c), d_max → 0 (no numbers published)",
         "match": {"scene": "atrium", "method": "hbao", "effect": "ao", "d_max": SMALL_D_MAX,
                   "falloff": "quadratic"}},
    ),
    claims=(
        Claim("LDMs are faster than HBAO at large d_max", "ldm", "hbao", ("time_ms",), "less",
              where="Fig. 8; §5.1 'LDMs are also faster than HBAO for large d_max'"),
        Claim("LDMs resemble the reference better than HBAO at large d_max (PSNR and SSIM)", "ldm", "hbao",
              ("psnr", "ssim"), "better", where="Fig. 8 caption; §5.1",
              published="shown with images only (no error numbers)"),
        Claim("HBAO gets slower as d_max grows (larger kernel)", "hbao", "hbao-small", ("time_ms",), "greater",
              where="§5.1 'the performance of HBAO drops due to the large kernel size'",
              published="stated in the text (no numbers)"),
        Claim("For small d_max the reverse: HBAO is faster than LDMs", "hbao-small", "ldm-small", ("time_ms",),
              "less", where="§5.1 'As d_max → 0, the reverse conclusion can be made'",
              published="stated in the text (no numbers)"),
    ),
    scales={"paper": {}, "ci": _CI_AALUND},
    notes=(
        "Scene: `atrium` (260,000 triangles) stands in for Crytek Sponza (262,267). d_max is scaled by "
        f"length: 1280 Sponza units / 3720.9 units × 30 m = {FIG8_D_MAX} m.",
        "'Attenuated visibility function' is read as the quadratic falloff rho(t) = 1 − (t/d_max)², HBAO's "
        "attenuation W(r) = 1 − r²/R² (Bavoil et al. 2008); the paper does not give the formula.",
        "The paper's HBAO parameters are not published; ours: the 2008 formula with 8 directions × 8 steps, "
        "radius clamp raised to the image diagonal (max_radius_px) so the kernel grows with d_max.",
        "Memory: the caption's 805.5 MB is for the LDMs; MB read as 2^20 bytes.",
    ),
)

AALUND2015_FIG9 = Reproduction(
    key="aalund2015-fig9",
    paper="aalund2015",
    title="LDM configurations: 512 low-resolution LDMs, unattenuated AO (Figure 9)",
    source="Figure 9 and its caption (200×200 memory from the Figure 8 and 10 captions); §5.1",
    hardware="NVIDIA GeForce GTX 780 Ti",
    resolution="800x800",
    paper_scene="Crytek Sponza (262k triangles) and a hairball",
    suite="suites/aalund2015-fig9.toml",
    rows=(
        {"id": "sponza-50", "label": "Fig. 9(a) LDMs, Sponza",
         "paper_setup": "Crytek Sponza, 512 LDMs of 50×50, unattenuated",
         "match": {"scene": "atrium", "method": "ldm-ao", "effect": "ao", "d_max": math.inf,
                   "params": {"directions": 512, "resolution": 50}},
         "time_ms": 373.0, "memory_mb": 204.1},
        {"id": "hairball-50", "label": "Fig. 9(c) LDMs, hairball",
         "paper_setup": "hairball, 512 LDMs of 50×50, unattenuated",
         "match": {"scene": "hairball", "method": "ldm-ao", "effect": "ao", "d_max": math.inf,
                   "params": {"directions": 512, "resolution": 50}},
         "time_ms": 1174.0, "memory_mb": 295.5},
        {"id": "sponza-200", "label": "512 LDMs of 200×200, Sponza",
         "paper_setup": "Crytek Sponza, 512 LDMs of 200×200 (memory from the Fig. 8/10 captions; "
                        "the 512.4 ms of Fig. 8 is attenuated AO, not comparable)",
         "match": {"scene": "atrium", "method": "ldm-ao", "effect": "ao", "d_max": math.inf,
                   "params": {"directions": 512, "resolution": 200}},
         "memory_mb": 805.5},
    ),
    claims=(
        Claim("512 low-resolution LDMs (50²) are faster than 200² ones", "sponza-50", "sponza-200", ("time_ms",),
              "less", where="§5.1 'trade quality for performance by using fewer low-resolution LDMs'",
              published="373.0 ms (Fig. 9, unattenuated) vs 512.4 ms (Fig. 8, attenuated)"),
        Claim("…at a cost in quality: 200² LDMs are more accurate than 50² (PSNR and SSIM)", "sponza-200",
              "sponza-50", ("psnr", "ssim"), "better", where="§5.1",
              published="stated in the text (no numbers)"),
        Claim("200² LDMs use ~4× the memory of 50² LDMs (805.5 / 204.1 = 3.95)", "sponza-200", "sponza-50",
              ("memory_mb",), "ratio", ratio=(3.95 / 1.5, 3.95 * 1.5), where="Fig. 8 and Fig. 9 captions"),
        Claim("The hairball's LDMs take more memory than Sponza's (295.5 vs 204.1 MB)", "hairball-50",
              "sponza-50", ("memory_mb",), "greater", where="Fig. 9 caption"),
        Claim("The hairball is slower than Sponza (1174 vs 373.0 ms)", "hairball-50", "sponza-50",
              ("time_ms",), "greater", where="Fig. 9"),
    ),
    scales={"paper": {}, "ci": _CI_AALUND},
    notes=(
        "Unattenuated visibility = classic AO: d_max = ∞ (step falloff).",
        "Scenes: `atrium` (260,000 triangles) for Crytek Sponza; `hairball` for the paper's hairball, whose "
        "size the paper does not give (the suite uses 2.88 M triangles, the size of McGuire's hairball).",
        "The published memory ratio of 200² to 50² LDMs is 805.5 / 204.1 = 3.95×, although the maps have 16× "
        "the texels: the paper's LDM memory is not proportional to the texel count.",
        "The 50² vs 200² time claim compares Fig. 9 (unattenuated) with Fig. 8 (attenuated, d_max = 1280 m) in "
        "the paper; ours compares both resolutions on the same unattenuated AO.",
    ),
)

REGISTRY: dict[str, Reproduction] = {r.key: r for r in (AALUND2015_FIG8, AALUND2015_FIG9)}


# --------------------------------------------------------------------------------------------------
# scaling a suite and its rows


def _map(value, override):
    """Apply one override: a dict maps old → new (unlisted values unchanged), anything else replaces."""
    if isinstance(override, dict):
        for k, v in override.items():
            if _same(k, value):
                return v
        return value
    return override


def _same(a, b) -> bool:
    if isinstance(a, str) or isinstance(b, str):
        return str(a) == str(b)
    try:
        fa, fb = float(a), float(b)
    except (TypeError, ValueError):
        return a == b
    if math.isinf(fa) or math.isinf(fb):
        return fa == fb
    return math.isclose(fa, fb, rel_tol=1e-6, abs_tol=1e-9)


def scale_suite(suite, scale: dict, size: str | None = None):
    """Apply a scale's overrides (size, spp, warmup, frames, method params, scene params) to a suite's
    jobs; duplicates created by the overrides are dropped."""
    from methods.base import registry
    from .suite import parse_size

    jobs, seen = [], set()
    w_h = parse_size(size) if size else (parse_size(scale["size"]) if scale.get("size") else None)
    for j in suite.jobs:
        params = dict(j.params)
        for k, ov in scale.get("params", {}).get(j.method, {}).items():
            if k in params or not isinstance(ov, dict):
                params[k] = _map(params.get(k), ov)
        sparams = dict(j.scene_params)
        for k, ov in scale.get("scene_params", {}).get(j.scene, {}).items():
            sparams[k] = _map(sparams.get(k), ov)
        try:
            registry()[j.method].Params.from_dict(params, method=j.method)
        except KeyError:
            pass  # unknown methods are rejected by the suite loader already
        nj = dataclasses.replace(
            j, params=tuple(sorted(params.items())), scene_params=tuple(sorted(sparams.items())),
            width=w_h[0] if w_h else j.width, height=w_h[1] if w_h else j.height,
            spp=int(scale.get("spp", j.spp)), warmup=int(scale.get("warmup", j.warmup)),
            frames=int(scale.get("frames", j.frames)))
        key = (nj.scene, nj.scene_params, nj.method, nj.params, nj.effect, nj.width, nj.height)
        if key not in seen:
            seen.add(key)
            jobs.append(nj)
    return dataclasses.replace(suite, jobs=jobs)


def scale_match(match: dict, scale: dict) -> dict:
    m = dict(match)
    meth = m.get("method")
    if "params" in m:
        ov = scale.get("params", {}).get(meth, {})
        m["params"] = {k: (_map(v, ov[k]) if k in ov else v) for k, v in m["params"].items()}
    if "scene_params" in m:
        ov = scale.get("scene_params", {}).get(m.get("scene"), {})
        m["scene_params"] = {k: (_map(v, ov[k]) if k in ov else v) for k, v in m["scene_params"].items()}
    return m


# --------------------------------------------------------------------------------------------------
# matching our rows


def _row_dmax(r):
    from .figures import d_max_of

    return d_max_of(r["effect_params"]) if isinstance(r["effect_params"], dict) else None


def _matches(r, m: dict) -> bool:
    if r.get("status") != "ok":
        return False
    for k in ("scene", "method", "effect"):
        if k in m and str(r.get(k)) != str(m[k]):
            return False
    ep = r["effect_params"] if isinstance(r["effect_params"], dict) else {}
    if "d_max" in m:
        d = _row_dmax(r)
        if d is None or not _same(d, m["d_max"]):
            return False
    if "falloff" in m and ep.get("falloff", "step") != m["falloff"]:
        return False
    if "size" in m and f"{r.get('width')}x{r.get('height')}" != m["size"]:
        return False
    for col, key in (("params", "params"), ("scene_params", "scene_params")):
        want = m.get(key) or {}
        have = r.get(col) if isinstance(r.get(col), dict) else {}
        if any(k not in have or not _same(have[k], v) for k, v in want.items()):
            return False
    return True


def find_row(rows: list, match: dict):
    """Our row for a published row: the matching successful row (the largest image when several)."""
    cands = [r for r in rows if _matches(r, match)]
    if not cands:
        return None, 0
    cands.sort(key=lambda r: -(int(r.get("width") or 0) * int(r.get("height") or 0)))
    return cands[0], len(cands)


def _shown_params(r, match) -> dict:
    """The parameters worth printing: those the row was matched on and those off their defaults."""
    try:
        from methods.base import registry

        defaults = registry()[r["method"]].Params().to_dict()
    except Exception:  # noqa: BLE001 - unknown method in an old run: show what we have
        defaults = {}
    want = match.get("params") or {}
    return {k: v for k, v in r["params"].items()
            if k in want or (k in defaults and not _same(defaults[k], v))}


def _noise(r):
    """Timing noise of a row: its interquartile range of frame times (ms), 0 when unknown."""
    try:
        v = float(r.get("total_ms_iqr"))
    except (TypeError, ValueError):
        return 0.0
    return 0.0 if math.isnan(v) else v


def our_value(r, q: str):
    if r is None:
        return None
    col = QUANTITIES[q][0]
    v = r.get(col)
    try:
        v = float(v)
    except (TypeError, ValueError):
        return None
    if math.isnan(v):
        return None
    return v / 2**20 if q == "memory_mb" else v


def _fmt(v, q=None) -> str:
    if v is None:
        return "–"
    unit = QUANTITIES[q][1] if q else ""
    if q in ("ssim", "flip"):
        s = f"{v:.3f}"
    elif q == "relmse":
        s = f"{v:.4f}"
    elif abs(v) >= 100:
        s = f"{v:.1f}"
    else:
        s = f"{v:.3g}" if abs(v) < 1 else f"{v:.2f}"
    return f"{s} {unit}".strip()


def _ratio(a, b) -> str:
    if a is None or b is None or b == 0:
        return "–"
    return f"{a / b:.3g}×"


# --------------------------------------------------------------------------------------------------
# evaluation


def _compare(kind, q, a, b, ratio=None):
    hib = QUANTITIES[q][2]
    if kind == "less":
        return a < b
    if kind == "greater":
        return a > b
    if kind == "better":
        return a > b if hib else a < b
    if kind == "ratio":
        return b != 0 and ratio[0] <= a / b <= ratio[1]
    raise LdbenchError(f"unknown claim kind {kind!r}")


def _side(kind, q, va, vb, ratio=None) -> str:
    if va is None or vb is None:
        return "–"
    if kind == "ratio":
        return f"{_fmt(va, q)} / {_fmt(vb, q)} = {va / vb:.2f}×" if vb else "–"
    return f"{_fmt(va, q)} vs {_fmt(vb, q)}"


def evaluate(entry: Reproduction, df, scale_name: str = "paper") -> dict:
    """Published vs ours for every row and claim of ``entry`` on a results table ``df``.

    Returns a JSON-able dict (also written as ``reproduce.json``): ``rows`` (one line per row ×
    quantity), ``claims`` (with verdicts), setup strings and notes.
    """
    from .figures import _as_dict

    scale = entry.scales.get(scale_name, {})
    recs = []
    for _, r in df.iterrows():
        d = r.to_dict()
        for c in ("params", "effect_params", "scene_params"):
            d[c] = _as_dict(d.get(c))
        recs.append(d)
    found = {}
    rows_out = []
    for pr in entry.rows:
        m = scale_match(pr["match"], scale)
        ours, n = find_row(recs, m)
        found[pr["id"]] = ours
        cfg = "no matching row in this run"
        if ours is not None:
            from .figures import fmt_value

            d = _row_dmax(ours)
            shown = _shown_params(ours, m)
            cfg = (f"{ours.get('scene')}"
                   + (f" ({', '.join(f'{k}={v}' for k, v in ours['scene_params'].items())})" if ours['scene_params'] else "")
                   + f", {ours.get('method')}" + (f" ({', '.join(f'{k}={fmt_value(v)}' for k, v in shown.items())})" if shown else "")
                   + (f", d_max = {fmt_value(d)}{'' if math.isinf(d) else ' m'} ({ours['effect_params'].get('falloff', 'step')})"
                      if d is not None else "")
                   + f", {ours.get('width')}×{ours.get('height')}" + (f" [{n} matches]" if n > 1 else ""))
        qs = [q for q in QUANTITIES if q in pr] or ["time_ms"]
        for q in qs:
            pub = pr.get(q)
            ov = our_value(ours, q)
            rows_out.append({"id": pr["id"], "label": pr["label"], "paper_setup": pr.get("paper_setup", ""),
                             "ours_config": cfg, "quantity": f"{QUANTITIES[q][3]}" + (f" ({QUANTITIES[q][1]})" if QUANTITIES[q][1] else ""),
                             "published": _fmt(pub, q) if pub is not None else "not published",
                             "ours": _fmt(ov, q), "ratio": _ratio(ov, pub),
                             "published_value": pub, "ours_value": ov})
    claims_out = []
    pub_rows = {pr["id"]: pr for pr in entry.rows}
    for c in entry.claims:
        ra, rb = found.get(c.a), found.get(c.b)
        parts, verdicts, pub_parts, noisy = [], [], [], False
        for q in c.quantities:
            va, vb = our_value(ra, q), our_value(rb, q)
            parts.append(_side(c.kind, q, va, vb, c.ratio))
            verdicts.append(None if va is None or vb is None else _compare(c.kind, q, va, vb, c.ratio))
            if q == "time_ms" and c.kind != "ratio" and va is not None and vb is not None:
                noisy |= abs(va - vb) <= max(_noise(ra), _noise(rb))
            pa, pb = pub_rows.get(c.a, {}).get(q), pub_rows.get(c.b, {}).get(q)
            if pa is not None and pb is not None:
                pub_parts.append(_side(c.kind, q, pa, pb, c.ratio))
        if any(v is None for v in verdicts):
            verdict = NOT_MEASURED
        elif noisy:
            verdict = INCONCLUSIVE
        else:
            verdict = HOLDS if all(verdicts) else FAILS
        published = c.published or "; ".join(pub_parts) or "stated in the paper"
        if c.kind == "ratio" and c.ratio:
            published += f" (holds if within {c.ratio[0]:.2f}–{c.ratio[1]:.2f}×)"
        claims_out.append({"text": c.text, "where": c.where, "published": published,
                           "ours": "; ".join(parts), "verdict": verdict})
    ok = df[df["status"] == "ok"] if "status" in df else df
    r0 = ok.iloc[0] if len(ok) else (df.iloc[0] if len(df) else None)
    if r0 is not None:
        sizes = sorted({f"{w}x{h}" for w, h in zip(df["width"], df["height"])})
        gpu = r0.get("gpu_name")
        our_setup = (f"device {r0.get('device')}, {r0.get('gl_renderer')}" + (f", GPU {gpu}" if gpu else "")
                     + f", {', '.join(sizes)}, scale '{scale_name}'")
    else:
        our_setup = "no rows"
    return {"key": entry.key, "paper": entry.paper, "title": entry.title, "source": entry.source,
            "published_setup": f"{entry.hardware}, {entry.resolution.replace('x', '×')}, {entry.paper_scene}",
            "our_setup": our_setup, "scale": scale_name, "device": None if r0 is None else r0.get("device"),
            "rows": rows_out, "claims": claims_out, "notes": list(entry.notes),
            "errors": [f"{r.get('scene')} {r.get('method')}: {r.get('status')}" for _, r in df.iterrows()
                       if r.get("status") != "ok"]}


# --------------------------------------------------------------------------------------------------
# printing


def _table(headers, rows) -> list[str]:
    widths = [max(len(str(h)), *(len(str(r[i])) for r in rows)) if rows else len(str(h))
              for i, h in enumerate(headers)]
    line = lambda cells: "  ".join(str(c).ljust(w) for c, w in zip(cells, widths)).rstrip()
    return [line(headers), line(["-" * w for w in widths])] + [line(r) for r in rows]


def format_text(res: dict) -> str:
    out = [f"{res['key']}: {res['title']}", f"  source:    {res['paper']}, {res['source']}",
           f"  published: {res['published_setup']}", f"  ours:      {res['our_setup']}"]
    if res.get("device") == "cpu-software":
        out.append("  note: device = cpu-software, our times are wall clock on a software rasterizer")
    out.append("")
    out += _table(["row", "quantity", "published", "ours", "ours/published", "our configuration"],
                  [[r["label"], r["quantity"], r["published"], r["ours"], r["ratio"], r["ours_config"]]
                   for r in res["rows"]])
    out.append("")
    out += _table(["claim", "published", "ours", "verdict"],
                  [[c["text"], c["published"], c["ours"], c["verdict"]] for c in res["claims"]])
    if res.get("errors"):
        out += ["", "failed rows:"] + [f"  {e}" for e in res["errors"]]
    out += [""] + [f"note: {n}" for n in res["notes"]]
    return "\n".join(out)


def _md(s) -> str:
    return str(s).replace("|", "\\|").replace("\n", " ")


def format_markdown(res: dict) -> str:
    out = [f"# {_md(res['key'])}: {_md(res['title'])}", "",
           f"- source: {_md(res['paper'])}, {_md(res['source'])}",
           f"- published: {_md(res['published_setup'])}", f"- ours: {_md(res['our_setup'])}"]
    if res.get("device") == "cpu-software":
        out.append("- **device = cpu-software: our times are wall clock on a software rasterizer**")
    out += ["", "| row | paper setup | our configuration | quantity | published | ours | ours / published |",
            "|---|---|---|---|---|---|---|"]
    for r in res["rows"]:
        out.append("| " + " | ".join(_md(x) for x in (r["label"], r["paper_setup"], r["ours_config"], r["quantity"],
                                                     r["published"], r["ours"], r["ratio"])) + " |")
    out += ["", "| claim | where | published | ours | verdict |", "|---|---|---|---|---|"]
    for c in res["claims"]:
        out.append("| " + " | ".join(_md(x) for x in (c["text"], c["where"], c["published"], c["ours"],
                                                     f"**{c['verdict']}**")) + " |")
    if res.get("errors"):
        out += ["", "Failed rows:", ""] + [f"- {_md(e)}" for e in res["errors"]]
    out += ["", "Notes:", ""] + [f"- {_md(n)}" for n in res["notes"]]
    return "\n".join(out) + "\n"


# --------------------------------------------------------------------------------------------------
# running


def get_entry(key: str) -> Reproduction:
    if key not in REGISTRY:
        raise LdbenchError(f"unknown table {key!r} (known: {', '.join(REGISTRY)}; see ldbench reproduce --list)")
    return REGISTRY[key]


def reproduce(key: str, *, scale: str = "paper", size: str | None = None, out=None, from_run=None,
              progress: bool = True, report: bool = True) -> tuple[dict, Path]:
    """Run (or reuse) the entry's suite, evaluate it, write ``reproduce.md``/``.json``; returns
    (result dict, run directory)."""
    from .records import read_results

    entry = get_entry(key)
    if scale not in entry.scales:
        raise LdbenchError(f"unknown scale {scale!r} for {key} (known: {', '.join(entry.scales)})")
    if from_run is not None:
        run_dir = Path(from_run)
        if not run_dir.is_dir():
            raise LdbenchError(f"--from-run: {run_dir} is not a directory")
        df = read_results(run_dir)
    else:
        from .runner import run_jobs
        from .suite import load_suite

        path = REPO / entry.suite
        if not path.is_file():
            raise LdbenchError(f"the suite of {key} is missing: {entry.suite}")
        suite = scale_suite(load_suite(path), entry.scales[scale], size)
        run_dir = Path(out) if out else REPO / "reports" / f"{key}-{scale}-{time.strftime('%Y%m%d-%H%M%S')}"
        run_jobs(suite, run_dir, progress=progress, report=False)
        df = read_results(run_dir)
    res = evaluate(entry, df, scale)
    (run_dir / "reproduce.json").write_text(json.dumps(res, indent=1, default=str), encoding="utf-8")
    (run_dir / "reproduce.md").write_text(format_markdown(res), encoding="utf-8")
    if report:
        from .report import write_report

        write_report(run_dir)
    return res, run_dir


def list_text() -> str:
    lines = []
    for e in REGISTRY.values():
        lines.append(f"{e.key:<18} {e.title}")
        lines.append(f"{'':<18} {e.paper} {e.source}; {e.hardware}, {e.resolution}; suite {e.suite}; "
                     f"scales: {', '.join(e.scales)}")
    return "\n".join(lines)


def main_cli(args) -> int:
    if args.list:
        print(list_text())
        return 0
    if not args.table:
        raise LdbenchError("ldbench reproduce needs a TABLE (see ldbench reproduce --list)")
    res, run_dir = reproduce(args.table, scale=args.scale, size=args.size, out=args.out,
                             from_run=args.from_run, progress=not args.no_progress,
                             report=not args.no_report)
    print(format_text(res))
    print(f"\nwrote {run_dir / 'reproduce.md'}")
    return 0
