"""Which rows of two runs are one benchmark, and what the benchmark is called.

Rows are matched by :data:`DEFAULT_MATCH` or by the keys given with ``--match``; method parameters in their
canonical form (:func:`canonical_params`). The helpers here read a row's values as plain Python
(:func:`row_value`, :func:`as_float`) for the rest of :mod:`ldbench.harness.compare`.
"""
from __future__ import annotations

import json
from pathlib import Path

import pandas as pd

from ldbench.core.errors import LdbenchError
from ldbench.core.scenes import builders
from ldbench.harness.records import check_columns, read_results
from ldbench.methods.base import canonical_name, get_method
from ldbench.reports.labels import effect_text

from .keys import DEFAULT_MATCH, MATCH_KEYS



#: Columns the gate reads besides the match keys; a table without one of them cannot be gated (a missing
#: ``psnr`` would otherwise pass every quality check as "n/a").
REQUIRED_COLUMNS = ("status", "total_ms", "raw_ms", "psnr", "ssim")


def check_schema(df, what: str, path, match=DEFAULT_MATCH) -> None:
    """Refuse a results table without a column the comparison needs (LdbenchError naming it)."""
    check_columns(df.columns, f"{what} {path}", (*match, *REQUIRED_COLUMNS))


def load_results(path, what: str = "results", match=DEFAULT_MATCH):
    """Results of a run directory or results file as a DataFrame (see :func:`records.read_results`).

    Raises :class:`LdbenchError` for a missing path, a directory without results, an empty table, or
    a table without the columns of ``match`` and :data:`REQUIRED_COLUMNS`.
    """
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

    r = pd.isna(v)  # NaN, pd.NA, NaT
    return bool(r) if isinstance(r, bool) or type(r).__name__ == "bool_" else False


def plain(v):
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
    v = plain(v)
    if isinstance(v, float) and v.is_integer():
        v = int(v)
    return json.dumps(v, sort_keys=True, default=str)


#: Columns holding JSON that :func:`records.read_results` may leave as text (extra columns).
_JSON_TEXT = ("scene_params",)


def row_value(row, col):
    v = plain(row[col]) if col in row.index else None
    if col in _JSON_TEXT and isinstance(v, str):
        try:
            v = json.loads(v)
        except ValueError:
            pass
    return v


def row_key(row, keys) -> tuple:
    out = []
    for k in keys:
        if k == "scene_params":  # defaults dropped, as for params: a new scene parameter orphans no baseline row
            out.append(canonical(canonical_scene_params(row_value(row, "scene"), row_value(row, k) or {})))
        elif k == "method":  # an adapter's earlier name (e.g. ldm-ao) matches its current one
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
    if not isinstance(params, dict):
        return params
    try:
        cls = get_method(str(method))
        defaults = cls.Params().to_dict()
    except (LdbenchError, TypeError):
        return params
    return _without_defaults(params, defaults, getattr(cls.Params, "renamed", None) or {})


def _without_defaults(params: dict, defaults: dict, renamed: dict | None = None) -> dict:
    """``params`` under their current names (``renamed``: old name -> current), every value equal to its
    default dropped."""
    out = {}
    for name, value in params.items():
        name = (renamed or {}).get(name, name)
        if name in defaults and canonical(value) == canonical(defaults[name]):
            continue
        out[name] = value
    return out


def canonical_scene_params(scene, params: dict) -> dict:
    """``params`` of a built-in scene as the match key sees them: every value equal to the scene builder's
    current default dropped (a row recorded before a scene parameter existed matches one recorded after).
    Other scenes' parameters (a registered scene's view) are returned as given."""
    cls = builders().get(str(scene)) if isinstance(params, dict) else None
    if cls is None:
        return params
    return _without_defaults(params, cls.Params().to_dict())


def index_rows(df, keys, what) -> dict:
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


def effect_label(row) -> str:
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
            parts = [scene, row_value(row, "method"), effect_label(row)]
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


def config_diff(brow, rrow) -> str:
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



def as_float(v) -> float | None:
    v = plain(v)
    return None if v is None else float(v)



def run_label(df, path) -> str:
    ids = sorted({str(x) for x in df["run_id"].dropna()}) if "run_id" in df else []
    commits = sorted({str(x)[:10] for x in df["commit"].dropna()}) if "commit" in df else []
    dirty = bool(df["dirty"].fillna(False).any()) if "dirty" in df else False
    parts = [f"`{path}`"]
    if ids:
        parts.append(f"run {', '.join(ids)}")
    if commits:
        parts.append(f"commit {', '.join(commits)}" + (" (dirty)" if dirty else ""))
    return ", ".join(parts)
