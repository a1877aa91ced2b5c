"""Validated parameters: :func:`param` declares a field (default, documentation, range or choices, the
paper's value) and :class:`ParamsBase` checks every field on construction, so an unknown or out-of-range
value is one clear error naming the parameter. Method adapters and effects declare their ``Params`` with
them (a frozen dataclass deriving from :class:`ParamsBase`).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from .errors import LdbenchError


def param(default, doc: str, *, lo=None, hi=None, choices=None, paper=None):
    """A validated parameter: ``lo``/``hi`` inclusive bounds, ``choices`` allowed values,
    ``paper`` the value the paper used (shown in ``ldbench methods``)."""
    return field(default=default, metadata={"doc": doc, "lo": lo, "hi": hi, "choices": choices,
                                            "paper": paper})


@dataclass(frozen=True)
class ParamsBase:
    """Base of every adapter's ``Params``: coerces types and checks ranges on construction."""

    def __post_init__(self):
        for f in dataclasses.fields(self):
            v, md = getattr(self, f.name), f.metadata
            v = coerce(type(f.default), v, f.name)
            if md.get("choices") is not None and v not in md["choices"]:
                raise LdbenchError(f"parameter {f.name}={v!r} not one of {list(md['choices'])}")
            if md.get("lo") is not None and not v >= md["lo"]:
                raise LdbenchError(f"parameter {f.name}={v!r} below its minimum {md['lo']}")
            if md.get("hi") is not None and not v <= md["hi"]:
                raise LdbenchError(f"parameter {f.name}={v!r} above its maximum {md['hi']}")
            object.__setattr__(self, f.name, v)

    @classmethod
    def from_dict(cls, values: dict, *, method: str = "") -> "ParamsBase":
        names = {f.name for f in dataclasses.fields(cls)}
        for k in values:
            if k not in names:
                raise LdbenchError(f"unknown parameter {k!r} for method {method!r} "
                                   f"(known: {', '.join(sorted(names)) or 'none'})")
        return cls(**values)

    def to_dict(self) -> dict:
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}

    @classmethod
    def field_names(cls) -> tuple:
        return tuple(f.name for f in dataclasses.fields(cls))

    @classmethod
    def table(cls) -> str:
        """A text table of the parameters: name, default, paper value, range, description."""
        rows = []
        for f in dataclasses.fields(cls):
            md = f.metadata
            rng = (f"{md['choices']}" if md.get("choices") else
                   f"[{md.get('lo', '')}, {md.get('hi', '')}]" if md.get("lo") is not None or md.get("hi") is not None
                   else "")
            paper = "" if md.get("paper") is None else f" (paper: {md['paper']})"
            rows.append(f"  {f.name:<16} = {f.default!r:<10} {rng:<18} {md.get('doc', '')}{paper}")
        return "\n".join(rows)


def coerce(kind, v, name):
    """``v`` as the declared type ``kind``, strictly: a bool only from a bool (or the text true/false
    of a command line), an int from an integer (not a bool) or integral text, a float from an int or
    float (not a bool) or numeric text (``inf``), a str from a str. Anything else is an error naming
    the parameter, never a silent conversion (``directions = true`` is not 1)."""
    import numbers

    bad = LdbenchError(f"parameter {name}={v!r} is not a valid {kind.__name__}")
    if kind is bool:
        if isinstance(v, (bool, np.bool_)):
            return bool(v)
        if isinstance(v, str) and v.strip().lower() in ("true", "false"):
            return v.strip().lower() == "true"
        raise bad
    if kind is int:
        if isinstance(v, numbers.Integral) and not isinstance(v, (bool, np.bool_)):
            return int(v)
        if isinstance(v, str):
            try:
                return int(v.strip())
            except ValueError:
                raise bad from None
        raise bad
    if kind is float:
        if isinstance(v, numbers.Real) and not isinstance(v, (bool, np.bool_)):
            x = float(v)
        elif isinstance(v, str):
            try:
                x = float(v.strip())  # also "inf" / "infinity"
            except ValueError:
                raise bad from None
        else:
            raise bad
        if math.isnan(x):
            raise bad
        return x
    if kind is str:
        if isinstance(v, str):
            return v
        raise bad
    return v
