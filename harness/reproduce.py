"""``ldbench reproduce``: one paper table or figure, our numbers beside the published ones.

This module is the engine (the :class:`Claim` and :class:`Reproduction` records, row matching,
verdicts, printing, the command); the papers' numbers are data in :mod:`harness.reproductions`, one
module per paper, collected by :func:`registry`. An entry is data:

* where the numbers come from (paper key, figure/table, the GPU and resolution the paper used),
* the suite that reproduces it (``suites/<name>.toml``, one of the bundled suites),
* ``rows``: a list of dicts, one per published row (or one per row of ours that a claim needs), each
  with a ``match`` that selects our result row (scene, method, effect, size, params, scene_params;
  any other key is a parameter of the effect, e.g. d_max, falloff) and the published values under the
  keys of :data:`QUANTITIES`,
* ``claims``: the paper's statements as comparisons between rows (:class:`Claim`), each with a verdict
  on our numbers: ``holds`` / ``does not hold on this machine`` / ``not measured`` (a row is missing or
  failed) / for times, ``inconclusive`` or ``not measurable here`` (see "Timing verdicts" below),
* ``scales``: suite overrides for ``--scale ci`` (tiny, for CI on llvmpipe) and ``--scale paper`` (the
  suite as written). A scale's parameter overrides are applied to the rows' ``match`` too, so the same
  rows find their counterparts at every scale.

Adding a paper (e.g. niessner2010 Table 1) is a data addition:

1. write the suite that runs our side, ``suites/<paper>-<table>.toml``;
2. add ``harness/reproductions/<paper>.py`` defining ``REPRODUCTIONS = (Reproduction(...), ...)``:
   the published rows (with the ``match`` that finds our row), the claims, the ``paper`` and ``ci``
   scales and notes on what was read into the paper (``aalund2015.py`` is the example);
3. ``ldbench reproduce --list`` shows it; ``tests/test_reproduce.py`` checks every entry's structure
   (suite present, claim rows exist, both scales) without further code.

No engine code changes: the module is found by :func:`registry` (pkgutil over the package).

Timing verdicts
---------------
A time claim compares two rows' medians (``total_ms``). On a GPU (timer queries) the verdict is
``inconclusive`` when the medians differ by no more than the larger of the two rows' interquartile
ranges. On a software rasterizer (either row's ``device`` is ``cpu-software``) frames are wall clock
on shared CPU cores and the load changes between the jobs of one run: over 10 back-to-back runs of
``aalund2015-fig8 --scale ci`` on a 2-core machine shared with other work, the median of one
configuration varied by up to 2.1× (6× with two runs at once), far beyond any row's IQR, and the IQR
rule let "HBAO gets slower as d_max grows" come out "holds" in 5 runs and "does not hold" in one.

The rule on cpu-software: the verdict is ``not measurable here`` unless the medians differ by more
than the run-to-run spread, the sum of the two rows' spreads. A row's spread is the full range
(max − min) of its raw per-frame totals (``raw_ms``); for a row stored without them, twice its IQR
(the range of three frames); with fewer than three frames it is unknown and the claim is not
measurable here. For a verdict to flip, both medians would have to move by more than the largest
variation seen within their own jobs, in opposite directions; over 16 such runs (6 of them two at a
time) no verdict flipped under this rule: each claim gave its one verdict or ``not measurable here``.

Quantities
----------
``time_ms`` ← ``total_ms`` (median frame time; GPU timer queries, or wall clock on a software
rasterizer), ``memory_mb`` ← ``memory_bytes`` / 2**20, ``psnr`` (dB), ``ssim``, ``flip``, ``relmse``,
the ray columns ``rays_per_s``, ``oracle_rays_per_s``, ``hit_agreement``, ``dist_err_p95``, and two
families: ``stage:NAME`` (the median time of a stage, ms, from ``stage_ms``; ``stage:a+b`` sums stages,
e.g. ``stage:count+fill`` for a build's two passes) and ``counter:NAME`` (a method counter, e.g.
``counter:fragments``). Stage times get the timing verdicts of ``time_ms``, with the whole frame's
noise.
The ratio column is ours / published: on different hardware (and a stand-in scene) it measures the
machine as much as the method, which is why the verdicts compare rows *within* our run (the paper's
claims are relative statements) and never our absolute numbers with the published ones.
"""
from __future__ import annotations

import dataclasses
import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

from .errors import LdbenchError
from .records import effect_d_max, effect_param


#: quantity → (our column, unit, higher is better, label)
QUANTITIES = {
    "time_ms": ("total_ms", "ms", False, "time"),
    "memory_mb": ("memory_bytes", "MB", False, "memory"),
    "psnr": ("psnr", "dB", True, "PSNR"),
    "ssim": ("ssim", "", True, "SSIM"),
    "flip": ("flip", "", False, "FLIP"),
    "relmse": ("relmse", "", False, "relMSE"),
    "rays_per_s": ("rays_per_s", "rays/s", True, "rays/s"),
    "hit_agreement": ("hit_agreement", "", True, "hit agreement"),
    "dist_err_p95": ("dist_err_p95", "", False, "p95 distance error / diagonal"),
    "oracle_rays_per_s": ("oracle_rays_per_s", "rays/s", True, "Mitsuba oracle rays/s"),
}
FAMILIES = ("stage:", "counter:")


def quantity(q: str) -> tuple:
    """(column, unit, higher is better, label) of a quantity: one of :data:`QUANTITIES`, ``stage:NAME``
    or ``counter:NAME`` (module docstring)."""
    if q in QUANTITIES:
        return QUANTITIES[q]
    if q.startswith("stage:") and q[6:]:
        return "stage_ms", "ms", False, f"{q[6:]} stage time"
    if q.startswith("counter:") and q[8:]:
        return "counters", "", True, q[8:]
    raise LdbenchError(f"unknown quantity {q!r} (known: {', '.join(QUANTITIES)}, stage:NAME, counter:NAME)")


def row_quantities(row: dict) -> list:
    """The quantities a published row gives: keys of :data:`QUANTITIES` in that order, then its
    ``stage:`` and ``counter:`` keys in their own order."""
    return [q for q in QUANTITIES if q in row] + [k for k in row if k.startswith(FAMILIES)]

HOLDS = "holds"
FAILS = "does not hold on this machine"
NOT_MEASURED = "not measured"
INCONCLUSIVE = "inconclusive (difference within the timing noise)"
NOT_MEASURABLE = "not measurable here"  # a time claim on cpu-software within the run-to-run spread

CPU_SOFTWARE = "cpu-software"
MIN_SPREAD_FRAMES = 3  # fewer frames than this give no spread: time claims on a CPU are not measurable


@dataclass(frozen=True)
class Claim:
    """A statement of the paper as a comparison between two rows (by ``id``).

    ``kind``:

    * ``"less"`` / ``"greater"``: row ``a``'s value is below / above row ``b``'s for every quantity;
    * ``"better"``: ``a`` beats ``b`` on every quantity (lower time/memory/FLIP/relMSE, higher PSNR/SSIM);
    * ``"ratio"``: a / b of the first quantity lies within ``ratio`` = (lo, hi);
    * ``"gap"``: a / b exceeds c / d for every quantity (rows ``c`` and ``d``): "the gap grows".

    ``b_quantity``: compare a's quantity with this quantity of b (e.g. two stages of one row, a = b);
    default: the same quantity on both sides.
    """

    text: str
    a: str
    b: str
    quantities: tuple = ("time_ms",)
    kind: str = "less"
    ratio: tuple | None = None
    where: str = ""  # where the paper says it (figure, section)
    published: str = ""  # the published evidence when not a pair of numbers (e.g. "images only")
    c: str = ""  # kind "gap": the second pair
    d: str = ""
    b_quantity: str = ""


@dataclass(frozen=True)
class Reproduction:
    key: str
    paper: str
    title: str
    source: str  # figure / table and section in the paper
    hardware: str  # the paper's GPU
    resolution: str  # the paper's image size
    paper_scene: str
    suite: str  # a bundled suite, "suites/<name>.toml"
    rows: tuple  # dicts, see the module docstring
    claims: tuple = ()
    scales: dict = field(default_factory=dict)
    notes: tuple = ()


def registry() -> dict[str, Reproduction]:
    """{key: entry} of every ``REPRODUCTIONS`` in the modules of :mod:`harness.reproductions`, in
    module order (found with pkgutil; modules starting with ``_`` are skipped)."""
    global _REGISTRY
    if _REGISTRY is None:
        import importlib
        import pkgutil

        from . import reproductions

        found: dict[str, Reproduction] = {}
        for mod in sorted(pkgutil.iter_modules(reproductions.__path__), key=lambda m: m.name):
            if mod.name.startswith("_"):
                continue
            m = importlib.import_module(f"{reproductions.__name__}.{mod.name}")
            entries = getattr(m, "REPRODUCTIONS", None)
            if not isinstance(entries, tuple) or not all(isinstance(e, Reproduction) for e in entries):
                raise TypeError(f"{m.__name__} must define REPRODUCTIONS, a tuple of Reproduction entries")
            for e in entries:
                if e.key in found:
                    raise ValueError(f"reproduction {e.key!r} is defined twice ({m.__name__})")
                found[e.key] = e
        _REGISTRY = found
    return _REGISTRY


_REGISTRY: dict | None = None


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


def _method(name) -> str:
    """The registered name of a method named by its name or an alias (as given when unknown), so that
    data written with an older name still finds its rows and overrides."""
    try:
        from methods.base import get_method

        return get_method(str(name)).name
    except Exception:  # noqa: BLE001 - unknown method (an old run): compare names as they are
        return str(name)


def _method_overrides(scale: dict, method) -> dict:
    """A scale's parameter overrides for one method (keys of ``scale["params"]`` may be aliases)."""
    return next((ov for k, ov in scale.get("params", {}).items() if _method(k) == _method(method)), {})


def scale_suite(suite, scale: dict, size: str | None = None):
    """Apply a scale's overrides (size, spp, warmup, frames, method params, scene params) to a suite's
    jobs; duplicates created by the overrides are dropped."""
    from methods.base import get_method
    from .suite import parse_size

    jobs, seen = [], set()
    w_h = parse_size(size) if size else (parse_size(scale["size"]) if scale.get("size") else None)
    for j in suite.jobs:
        params = dict(j.params)
        for k, ov in _method_overrides(scale, j.method).items():
            if k in params or not isinstance(ov, dict):
                params[k] = _map(params.get(k), ov)
        sparams = dict(j.scene_params)
        for k, ov in scale.get("scene_params", {}).get(j.scene, {}).items():
            sparams[k] = _map(sparams.get(k), ov)
        try:
            cls = get_method(j.method)
        except LdbenchError:
            cls = None  # unknown methods are rejected by the suite loader already
        if cls is not None:
            cls.Params.from_dict(params, method=j.method)  # an override the method rejects is an error
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
    if "params" in m:
        ov = _method_overrides(scale, m.get("method"))
        m["params"] = {k: (_map(v, ov[k]) if k in ov else v) for k, v in m["params"].items()}
    if "scene_params" in m:
        ov = scale.get("scene_params", {}).get(m.get("scene"), {})
        m["scene_params"] = {k: (_map(v, ov[k]) if k in ov else v) for k, v in m["scene_params"].items()}
    return m


# --------------------------------------------------------------------------------------------------
# matching our rows


#: Keys of a row's ``match`` that are not effect parameters.
_MATCH_ROW_KEYS = ("scene", "method", "effect", "size", "params", "scene_params")


def _matches(r, m: dict) -> bool:
    if r.get("status") != "ok":
        return False
    for k in ("scene", "effect"):
        if k in m and str(r.get(k)) != str(m[k]):
            return False
    if "method" in m and _method(r.get("method")) != _method(m["method"]):
        return False
    for k, want in m.items():  # every other key is an effect parameter (d_max, falloff, ...)
        if k not in _MATCH_ROW_KEYS:
            have = effect_d_max(r) if k == "d_max" else effect_param(r, k)
            if have is None or not _same(have, want):
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
        from methods.base import get_method

        defaults = get_method(r["method"]).Params().to_dict()
    except Exception:  # noqa: BLE001 - unknown method in an old run: show what we have
        defaults = {}
    want = match.get("params") or {}
    return {k: v for k, v in r["params"].items()
            if k in want or (k in defaults and not _same(defaults[k], v))}


def _float(v):
    try:
        f = float(v)
    except (TypeError, ValueError):
        return None
    return None if math.isnan(f) else f


def _noise(r):
    """Timing noise of a row: its interquartile range of frame times (ms), 0 when unknown."""
    return _float(r.get("total_ms_iqr")) or 0.0


def _spread(r):
    """A row's timing spread on a software rasterizer (ms; see "Timing verdicts"): the range of its raw
    per-frame totals (wall clock when it has no totals), twice its IQR when it keeps no raw samples,
    None when unknown (fewer than three frames)."""
    raw = r.get("raw_ms") if isinstance(r.get("raw_ms"), dict) else {}
    samples = [x for x in map(_float, raw.get("total") or raw.get("wall") or []) if x is not None]
    if samples:
        return max(samples) - min(samples) if len(samples) >= MIN_SPREAD_FRAMES else None
    frames, iqr = _float(r.get("frames")), _float(r.get("total_ms_iqr"))
    return 2.0 * iqr if iqr is not None and frames is not None and frames >= MIN_SPREAD_FRAMES else None


def time_verdict(ra, rb, va: float, vb: float, kind: str = "less"):
    """The verdict two rows' times force on a claim, or None when the comparison stands.

    cpu-software (either row): :data:`NOT_MEASURABLE` unless ``|va − vb|`` exceeds the sum of the rows'
    :func:`_spread`; otherwise (GPU timer queries): :data:`INCONCLUSIVE` when ``|va − vb|`` is within the
    larger interquartile range (not for ratio claims).
    """
    if CPU_SOFTWARE in (ra.get("device"), rb.get("device")):
        sa, sb = _spread(ra), _spread(rb)
        return NOT_MEASURABLE if sa is None or sb is None or abs(va - vb) <= sa + sb else None
    if kind != "ratio" and abs(va - vb) <= max(_noise(ra), _noise(rb)):
        return INCONCLUSIVE
    return None


def our_value(r, q: str):
    if r is None:
        return None
    col = quantity(q)[0]
    v = r.get(col)
    if q.startswith(FAMILIES):
        from .figures import as_dict

        d = as_dict(v) or {}
        names = q.split(":", 1)[1].split("+")
        vals = [_float(d.get(n)) for n in names]
        return None if any(x is None for x in vals) else float(sum(vals))
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
    unit = quantity(q)[1] if q else ""
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
    hib = quantity(q)[2]
    if kind == "less":
        return a < b
    if kind == "greater":
        return a > b
    if kind == "better":
        return a > b if hib else a < b
    if kind == "ratio":
        return b != 0 and ratio[0] <= a / b <= ratio[1]
    if kind == "gap":  # a, b: the two ratios
        return a > b
    raise LdbenchError(f"unknown claim kind {kind!r}")


def _side(kind, q, va, vb, ratio=None) -> str:
    if va is None or vb is None:
        return "–"
    if kind == "gap":
        return f"{va:.3g}× vs {vb:.3g}×"
    if kind == "ratio":
        return f"{_fmt(va, q)} / {_fmt(vb, q)} = {va / vb:.2f}×" if vb else "–"
    return f"{_fmt(va, q)} vs {_fmt(vb, q)}"


def evaluate(entry: Reproduction, df, scale_name: str = "paper") -> dict:
    """Published vs ours for every row and claim of ``entry`` on a results table ``df``.

    Returns a JSON-able dict (also written as ``reproduce.json``): ``rows`` (one line per row ×
    quantity), ``claims`` (with verdicts), setup strings and notes.
    """
    from .figures import as_dict

    scale = entry.scales.get(scale_name, {})
    recs = []
    for _, r in df.iterrows():
        d = r.to_dict()
        for c in ("params", "effect_params", "scene_params", "raw_ms"):
            d[c] = as_dict(d.get(c))
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

            d = effect_d_max(ours)
            shown = _shown_params(ours, m)
            cfg = (f"{ours.get('scene')}"
                   + (f" ({', '.join(f'{k}={v}' for k, v in ours['scene_params'].items())})" if ours['scene_params'] else "")
                   + f", {ours.get('method')}" + (f" ({', '.join(f'{k}={fmt_value(v)}' for k, v in shown.items())})" if shown else "")
                   + (f", d_max = {fmt_value(d)}{'' if math.isinf(d) else ' m'} ({effect_param(ours, 'falloff', 'step')})"
                      if d is not None else "")
                   + f", {ours.get('width')}×{ours.get('height')}" + (f" [{n} matches]" if n > 1 else ""))
        qs = row_quantities(pr) or ["time_ms"]
        for q in qs:
            pub = pr.get(q)
            ov = our_value(ours, q)
            rows_out.append({"id": pr["id"], "label": pr["label"], "paper_setup": pr.get("paper_setup", ""),
                             "ours_config": cfg, "quantity": f"{quantity(q)[3]}" + (f" ({quantity(q)[1]})" if quantity(q)[1] else ""),
                             "published": _fmt(pub, q) if pub is not None else "not published",
                             "ours": _fmt(ov, q), "ratio": _ratio(ov, pub),
                             "published_value": pub, "ours_value": ov})
    claims_out = []
    pub_rows = {pr["id"]: pr for pr in entry.rows}
    for c in entry.claims:
        ra, rb = found.get(c.a), found.get(c.b)
        parts, verdicts, pub_parts, timing = [], [], [], set()
        for q in c.quantities:
            qb = c.b_quantity or q
            va, vb = our_value(ra, q), our_value(rb, qb)
            pa, pb = pub_rows.get(c.a, {}).get(q), pub_rows.get(c.b, {}).get(qb)
            timed = [(ra, rb, va, vb)]
            if c.kind == "gap":  # compare a/b with c/d: the sides become the two ratios
                rc, rd = found.get(c.c), found.get(c.d)
                vc, vd = our_value(rc, q), our_value(rd, q)
                timed.append((rc, rd, vc, vd))
                va = va / vb if None not in (va, vb) and vb else None
                vb = vc / vd if None not in (vc, vd) and vd else None
                pc, pd = pub_rows.get(c.c, {}).get(q), pub_rows.get(c.d, {}).get(q)
                pa = pa / pb if None not in (pa, pb) and pb else None
                pb = pc / pd if None not in (pc, pd) and pd else None
            parts.append(_side(c.kind, q, va, vb, c.ratio))
            verdicts.append(None if va is None or vb is None else _compare(c.kind, q, va, vb, c.ratio))
            if q == "time_ms" or q.startswith("stage:"):
                for r1, r2, v1, v2 in timed:
                    if None not in (r1, r2, v1, v2):
                        timing.add(time_verdict(r1, r2, v1, v2, "ratio" if c.kind == "gap" else c.kind))
            if pa is not None and pb is not None:
                pub_parts.append(_side(c.kind, q, pa, pb, c.ratio))
        if any(v is None for v in verdicts):
            verdict = NOT_MEASURED
        elif NOT_MEASURABLE in timing or INCONCLUSIVE in timing:
            verdict = NOT_MEASURABLE if NOT_MEASURABLE in timing else INCONCLUSIVE
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
        out.append("  note: device = cpu-software, our times are wall clock on a software rasterizer; a time "
                   "claim is 'not measurable here' unless the difference exceeds the run-to-run spread")
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
        out.append("- **device = cpu-software: our times are wall clock on a software rasterizer**; a time "
                   "claim is *not measurable here* unless the difference exceeds the run-to-run spread")
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


def suite_file(entry: Reproduction) -> Path:
    """The entry's suite among the bundled suites (``suites/`` of a checkout, ``harness/suites`` of an
    installed package)."""
    from .resources import SUITES_DIR

    return SUITES_DIR / Path(entry.suite).name


def get_entry(key: str) -> Reproduction:
    reg = registry()
    if key not in reg:
        raise LdbenchError(f"unknown table {key!r} (known: {', '.join(reg)}; see ldbench reproduce --list)")
    return reg[key]


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
        from .executors import run_jobs
        from .suite import load_suite

        path = suite_file(entry)
        if not path.is_file():
            raise LdbenchError(f"the suite of {key} is missing: {entry.suite}")
        suite = scale_suite(load_suite(path), entry.scales[scale], size)
        run_dir = Path(out) if out else Path("runs") / f"{key}-{scale}-{time.strftime('%Y%m%d-%H%M%S')}"
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
    for e in registry().values():
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
