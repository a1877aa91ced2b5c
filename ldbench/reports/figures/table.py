"""A results table prepared for the figures (:func:`prepare`): parsed columns, the effect's text and file-name
form, the swept parameters, and the row labels the figures share."""
from __future__ import annotations

import json
import math

import numpy as np

from ldbench.core.effects import effect_from_key
from ldbench.core.effects.base import effect_columns
from ldbench.harness.records import effect_d_max, effect_param
from ldbench.reports import labels
from ldbench.reports.labels import as_number

#: 1 MB in the report: 2**20 bytes (MiB), as in ``summary.md``.
MB = float(2**20)

#: The effects' numeric metric columns (:attr:`~ldbench.core.effects.base.EffectSpec.columns`), read as
#: numbers by :func:`prepare`.
NUMERIC_COLUMNS = tuple(c for c, kind in effect_columns().items() if kind in ("int", "float"))


def as_dict(v) -> dict:
    """A column's dict, parsed where a results file stores it as JSON text; {} for anything else."""
    if isinstance(v, dict):
        return v
    if isinstance(v, str) and v.strip():
        try:
            d = json.loads(v)
            return d if isinstance(d, dict) else {}
        except ValueError:
            return {}
    return {}


def effect_text(r) -> str:
    """``ao (quadratic, d_max = 10.3)``, ``rays (diffuse, rays_per_pixel = 4)``: the effect's own text
    (:func:`ldbench.reports.labels.effect_text`)."""
    return labels.effect_text(r["effect"], r["effect_params"])


def effect_slug(r) -> str:
    """Short file-name form of the effect: ``ao-quadratic-d10.32``, ``ao-step-dinf``, ``direct``,
    ``rays-diffuse-4`` (the effect's own label when the effect is registered)."""
    try:
        return effect_from_key({**r["effect_params"], "effect": r["effect"]}).label()
    except Exception:  # noqa: BLE001 - an unknown effect in an old table: its name
        return str(r["effect"])


def prepare(df):
    """A copy of a results table with parsed helper columns used by the report.

    Adds ``params``/``effect_params``/``scene_params``/``images``/``stage_ms`` as dicts, ``d_max``
    (float, inf, or None), ``falloff``, ``size`` ("WxH"), ``pixels``, ``memory_mb``, ``effect_text``
    and ``sweep`` (the dict of every sweepable parameter of the row, see :mod:`ldbench.reports.figures`).
    """
    df = df.copy().reset_index(drop=True)
    for c in ("params", "effect_params", "scene_params", "images", "stage_ms", "counters", "memory",
              "stage_iqr", "metric_settings"):
        df[c] = [as_dict(v) for v in (df[c] if c in df else [None] * len(df))]
    for c in ("scene", "method", "effect", "status", "scene_hash", "device"):
        if c not in df:
            df[c] = None
    df["d_max"] = [effect_d_max(r) for _, r in df.iterrows()]
    df["falloff"] = [effect_param(r, "falloff") for _, r in df.iterrows()]
    w = [int(x) if as_number(x) is not None else 0 for x in df.get("width", [0] * len(df))]
    h = [int(x) if as_number(x) is not None else 0 for x in df.get("height", [0] * len(df))]
    df["size"] = [f"{a}x{b}" for a, b in zip(w, h)]
    df["pixels"] = [a * b for a, b in zip(w, h)]
    mem = df["memory_bytes"] if "memory_bytes" in df else [None] * len(df)
    df["memory_mb"] = [(as_number(m) / MB) if as_number(m) is not None else math.nan for m in mem]
    for c in ("total_ms", "total_ms_iqr", "wall_ms", *NUMERIC_COLUMNS):
        values = df[c] if c in df else [None] * len(df)
        df[c] = [(as_number(v) if as_number(v) is not None else math.nan) for v in values]
    q1, q3 = [], []
    for raw, med in zip(df["raw_ms"] if "raw_ms" in df else [None] * len(df), df["total_ms"]):
        tot = as_dict(raw).get("total") if raw is not None else None
        vals = [x for x in (as_number(t) for t in (tot or [])) if x is not None]
        if vals:
            a, b = np.percentile(vals, [25, 75])
            q1.append(float(a)), q3.append(float(b))
        else:
            q1.append(math.nan), q3.append(math.nan)
    df["total_q1"], df["total_q3"] = q1, q3
    df["effect_text"] = [effect_text(r) for _, r in df.iterrows()]
    df["effect_slug"] = [effect_slug(r) for _, r in df.iterrows()]
    sweeps = []
    for _, r in df.iterrows():
        s = {k: v for k, v in r["params"].items() if not isinstance(v, (dict, list))}
        if r["d_max"] is not None:
            s["d_max"] = r["d_max"]
        for k, v in r["scene_params"].items():
            if not isinstance(v, (dict, list)):
                s[f"scene.{k}"] = v
        s["pixels"] = r["pixels"]
        sweeps.append(s)
    df["sweep"] = sweeps
    return df


def sortable(v):
    """Sort key mixing numbers (numeric order, inf last) and text."""
    n = as_number(v) if not isinstance(v, str) else None
    return (0, n, "") if n is not None else (1, 0.0, str(v))


def ok_rows(df):
    """The rows whose status is ``ok`` (a failed row has no times or images to draw)."""
    return df[df["status"] == "ok"]


def swept_parameters(df) -> list[str]:
    """Parameters that take more than one value within some (scene, method, effect) group."""
    out: list[str] = []
    ok = ok_rows(df)
    for _, g in ok.groupby(["scene", "method", "effect"], sort=False, dropna=False):
        keys = []
        for s in g["sweep"]:
            keys += [k for k in s if k not in keys]
        for k in keys:
            vals = {json.dumps(s.get(k), default=str) for s in g["sweep"]}
            if len(vals) > 1 and k not in out and all(as_number(s.get(k)) is not None or s.get(k) is None
                                                     for s in g["sweep"]):
                out.append(k)
    return out


def config_label(r, differing: list[str]) -> str:
    """The method on one line, what sets the row apart (:func:`ldbench.reports.labels.label_parts`) below."""
    parts = labels.label_parts(r, differing)
    return "\n".join([parts[0], ", ".join(parts[1:])]) if len(parts) > 1 else parts[0]
