"""Labels of results rows: the one rule for what sets a configuration apart, used by the report's tables,
figures and grids and by ``ldbench compare``.

A row's method parameters are read with the adapter's defaults filled in (:func:`param_value`): a row that
leaves a parameter at its default and a row that stores the default itself are the same configuration, and
a parameter the row's method does not have is no difference. An effect's label is its spec's own
(:meth:`ldbench.core.effects.base.EffectSpec.text`).
"""
from __future__ import annotations

import functools
import math

from ldbench.core.effects import effect_from_key
from ldbench.methods.base import get_method

#: the value :func:`param_value` gives for a parameter the row's method does not have
ABSENT = object()


def fmt_value(v) -> str:
    """Compact text for a parameter value (``inf`` → ∞, floats with %g)."""
    if isinstance(v, float):
        return "∞" if math.isinf(v) else f"{v:g}"
    return str(v)


def as_number(v):
    """float of a value, None when missing or not a number."""
    if v is None:
        return None
    try:
        f = float(v)
    except (TypeError, ValueError):
        return None
    return None if math.isnan(f) else f


def same(a, b) -> bool:
    """Parameter values equal after a records round trip (128 == 128.0, "inf" == inf, tuple == list)."""
    fa, fb = as_number(a), as_number(b)
    if fa is not None and fb is not None and not isinstance(a, bool) and not isinstance(b, bool):
        return fa == fb
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    return a == b or str(a) == str(b)


@functools.lru_cache(maxsize=None)
def defaults(method: str) -> tuple:
    """(defaults dict, renamed dict) of an adapter's ``Params``; ({}, {}) for a method this version
    does not know (then only what a row stores is known of it)."""
    try:
        cls = get_method(str(method)).Params
        return cls().to_dict(), dict(getattr(cls, "renamed", None) or {})
    except Exception:  # noqa: BLE001 - an old table may name a method that no longer exists
        return {}, {}


def params_of(method, params: dict) -> dict:
    """The row's parameters under their current names, the adapter's defaults filled in."""
    dflt, renamed = defaults(str(method))
    return {**dflt, **{renamed.get(k, k): v for k, v in (params or {}).items()}}


def param_value(row, key: str):
    """Parameter ``key`` of a row (its stored value, else its method's default), :data:`ABSENT` when the
    row's method has no such parameter."""
    return params_of(row["method"], row["params"]).get(key, ABSENT)


def effect_text(effect: str, effect_params: dict) -> str:
    """An effect as tables and figures write it, e.g. ``ao (quadratic, d_max = 10.3)``: its spec's
    :meth:`~ldbench.core.effects.base.EffectSpec.text`; for an effect this version does not know, its name
    and parameters."""
    try:
        return effect_from_key({**(effect_params or {}), "effect": effect}).text()
    except Exception:  # noqa: BLE001 - an unknown effect or old parameters in an old table
        rest = [(k, v) for k, v in (effect_params or {}).items() if k != "effect"]
        return f"{effect} (" + ", ".join(f"{k} = {fmt_value(v)}" for k, v in rest) + ")" if rest else str(effect)


def swept_params(rows) -> dict:
    """{method: the parameters that take more than one value among its rows}, the defaults filled in
    (rows need ``method`` and ``params`` only)."""
    by_method: dict = {}
    for r in rows:
        by_method.setdefault(str(r["method"]), []).append(params_of(r["method"], r["params"]))
    return {m: {k for k in {k for p in ps for k in p} if any(not same(ps[0].get(k), p.get(k)) for p in ps[1:])}
            for m, ps in by_method.items()}


def differing_keys(rows) -> list[str]:
    """What sets ``rows`` apart: ``scene``, ``effect``, ``size`` where they differ, then every method
    parameter that takes more than one value among the rows of one method (:func:`swept_params`)."""
    out = [k for k, col in (("scene", "scene"), ("effect", "effect_text"), ("size", "size"))
           if len({str(r[col]) for r in rows}) > 1]
    return out + sorted(set().union(*swept_params(rows).values()))


def label_parts(row, keys) -> list[str]:
    """``[method, part, ...]``: the row's value of each of ``keys`` (from :func:`differing_keys`); a parameter
    its method does not have is left out."""
    parts = [str(row["method"])]
    for k in keys:
        if k == "scene":
            parts.append(str(row["scene"]))
        elif k == "effect":
            parts.append(str(row["effect_text"]))
        elif k == "size":
            parts.append(str(row["size"]))
        else:
            v = param_value(row, k)
            if v is not ABSENT:
                parts.append(f"{k}={fmt_value(v)}")
    return parts
