"""Validated parameters: :func:`param` declares a field (default, documentation, range or choices, the
paper's value), :func:`group` a group of them, and :class:`ParamsBase` checks every field on
construction, so an unknown or out-of-range value is one clear error naming the parameter. Method
adapters and effects declare their ``Params`` with them (frozen dataclasses deriving from
:class:`ParamsBase`), and named sets of values as :class:`Preset` (``preset = "paper"``).
"""
from __future__ import annotations

import dataclasses
import math
import numbers
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from ldbench.core.errors import LdbenchError


def param(default, doc: str, *, lo=None, hi=None, choices=None, paper=None):
    """A validated parameter: ``doc`` its description, ``lo``/``hi`` inclusive bounds, ``choices`` allowed
    values, ``paper`` the value the paper used. This declaration is the parameter's only documentation:
    ``ldbench methods NAME`` and docs/reference/parameters.md are generated from it
    (:func:`ldbench.core.paramdoc.markdown`), so ``doc`` says what the parameter does and its unit where it
    has one, and default, range and choices are left to the generated table."""
    return field(default=default, metadata={"doc": doc, "lo": lo, "hi": hi, "choices": choices,
                                            "paper": paper})


@dataclass(frozen=True)
class Preset:
    """A named set of parameter values (flat names, dotted for grouped ones) that a suite or command line
    selects with ``preset = NAME`` (``--set ldm.preset=paper``); parameters given beside it win."""

    doc: str
    values: dict


#: the parameter name that selects a preset
PRESET_KEY = "preset"


def group(cls, doc: str, *, expose: tuple | None = None, choices: dict | None = None, paper: dict | None = None,
          when: dict | None = None, **defaults):
    """A parameter group: a field holding a nested :class:`ParamsBase` ``cls`` (e.g. the
    :class:`~ldbench.methods.structures.spec.StructureSpec` of a method's structure), whose parameters are named
    ``<field>.<name>`` (``cls.prefix`` must be ``"<field>."``). ``defaults``: this method's values of the
    group's fields; ``expose``: the fields a suite may set (None: all; the others stay at ``defaults``);
    ``choices``: narrower choices of a field for this method; ``paper``: the paper's value of a field;
    ``when``: defaults that follow a value a suite sets, ``{field: {value: {other field: its default}}}``
    (e.g. a source that allows only one assembly), applied to the fields the suite left unset."""
    return field(default_factory=lambda: cls(**defaults),
                 metadata={"group": cls, "doc": doc, "expose": expose, "choices": choices or {},
                           "paper_values": paper or {}, "defaults": defaults, "when": when or {}})


@dataclass(frozen=True)
class ParamsBase:
    """Base of every adapter's ``Params``: coerces types and checks ranges on construction.

    A method's parameters may be grouped by role (:func:`group`): the flat view (:meth:`to_dict`,
    :meth:`from_dict`, :meth:`field_names`) names a grouped parameter ``group.name``
    (``structure.source``, ``indirect.photons``). :attr:`renamed` maps each earlier flat name to its
    dotted name (and :attr:`renamed_values` an earlier name whose values changed vocabulary to the new
    parameters of each value), so suites and records written with the earlier names keep working."""

    #: the dotted prefix of this class's parameters in error messages ("structure." for a group)
    prefix: ClassVar[str] = ""
    #: earlier flat name -> its dotted name
    renamed: ClassVar[dict] = {}
    #: earlier flat name -> {earlier value: {dotted name: value, ...}} (a vocabulary that changed)
    renamed_values: ClassVar[dict] = {}
    #: name -> :class:`Preset`, selected by the parameter ``preset``
    presets: ClassVar[dict] = {}

    def __post_init__(self):
        for f in dataclasses.fields(self):
            v, md, name = getattr(self, f.name), f.metadata, self.prefix + f.name
            if "group" in md:
                object.__setattr__(self, f.name, self._group_value(f, v))
                continue
            v = _coerce(type(f.default), v, name)
            if md.get("choices") is not None and v not in md["choices"]:
                raise LdbenchError(f"parameter {name}={v!r} not one of {list(md['choices'])}")
            if md.get("lo") is not None and not v >= md["lo"]:
                raise LdbenchError(f"parameter {name}={v!r} below its minimum {md['lo']}")
            if md.get("hi") is not None and not v <= md["hi"]:
                raise LdbenchError(f"parameter {name}={v!r} above its maximum {md['hi']}")
            object.__setattr__(self, f.name, v)

    @staticmethod
    def _group_value(f, v):
        """The group field ``f``'s value: a dict of exposed parameters (over the method's defaults) or an
        instance of the group's class; narrower choices checked."""
        md, gcls = f.metadata, f.metadata["group"]
        if gcls.prefix != f.name + ".":
            raise TypeError(f"group {f.name}: {gcls.__name__}.prefix is {gcls.prefix!r}, not {f.name + '.'!r}")
        if isinstance(v, dict):
            exposed = _exposed(f)
            for k in v:
                if k not in exposed:
                    raise LdbenchError(f"unknown parameter {f.name}.{k} (known: "
                                       f"{', '.join(f'{f.name}.{n}' for n in exposed)})")
            for k, allowed in md["choices"].items():  # before the group's own checks: the narrower choice
                if isinstance(v.get(k), str) and v[k] not in allowed:
                    raise LdbenchError(f"parameter {f.name}.{k}={v[k]!r} not one of {list(allowed)}")
            follow = {}
            for k, table in md["when"].items():
                if k in v and v[k] in table:
                    follow.update({dk: dv for dk, dv in table[v[k]].items() if dk not in v})
            v = gcls(**{**md["defaults"], **follow, **v})
        elif not isinstance(v, gcls):
            raise LdbenchError(f"parameter group {f.name} must be a table of parameters, got {v!r}")
        for k, allowed in md["choices"].items():
            if getattr(v, k) not in allowed:
                raise LdbenchError(f"parameter {f.name}.{k}={getattr(v, k)!r} not one of {list(allowed)}")
        return v

    @classmethod
    def _groups(cls) -> dict:
        return {f.name: f for f in dataclasses.fields(cls) if "group" in f.metadata}

    @classmethod
    def upgrade(cls, values: dict) -> dict:
        """``values`` in the current flat names: earlier names through :attr:`renamed` and
        :attr:`renamed_values`, nested group tables (``{"structure": {"source": ...}}``, as TOML reads
        ``structure.source = ...``) flattened, and ``preset`` replaced by its values under the parameters
        given beside it. The same parameter given twice with two values is an error."""
        groups = cls._groups()
        out: dict[str, Any] = {}
        given: dict[str, str] = {}  # parameter -> how it was given, for the "given twice" message
        values = cls._expand_preset(values)
        flat = []
        for k, v in values.items():
            if k in groups and isinstance(v, dict):
                flat += [(f"{k}.{sk}", sv) for sk, sv in v.items()]
            else:
                flat.append((k, v))
        for k, v in flat:
            if k in cls.renamed_values:
                table = cls.renamed_values[k]
                key = v.strip() if isinstance(v, str) else v
                if key not in table:
                    raise LdbenchError(f"parameter {k}={v!r} (now {cls.renamed.get(k, k)}) not one of {list(table)}")
                items = table[key]
            else:
                items = {cls.renamed.get(k, k): v}
            for nk, nv in items.items():
                if nk in out and out[nk] != nv:
                    raise LdbenchError(f"parameter {nk} given twice: {given[nk]} and {k}={v!r}")
                out[nk], given[nk] = nv, f"{k}={v!r}"
        return out

    @classmethod
    def _expand_preset(cls, values: dict) -> dict:
        """``values`` with ``preset = NAME`` replaced by the preset's values; a value given beside it wins."""
        if PRESET_KEY not in values:
            return values
        values = dict(values)
        name = values.pop(PRESET_KEY)
        if name not in cls.presets:
            known = ", ".join(cls.presets) or "none"
            raise LdbenchError(f"parameter preset={name!r}: not a preset of this method (known: {known})")
        upgraded = cls.upgrade(values)  # compare in current names: an earlier name beside the preset wins too
        return {**{k: v for k, v in cls.presets[name].values.items() if k not in upgraded}, **values}

    @classmethod
    def with_presets(cls, shown: dict, full: dict) -> dict:
        """``shown``, some of a row's flat parameters ``full`` (current names), with a preset named instead
        of its values when ``full`` holds all of them (for printing which configuration a row ran)."""
        for name, pre in cls.presets.items():
            if pre.values and all(k in full and full[k] == v for k, v in pre.values.items()):
                return {PRESET_KEY: name, **{k: v for k, v in shown.items() if k not in pre.values}}
        return shown

    @classmethod
    def from_dict(cls, values: dict, *, method: str = "") -> "ParamsBase":
        """The parameters of a flat dict (dotted names for grouped ones; earlier names accepted)."""
        values = cls.upgrade(values)
        groups = cls._groups()
        names = set(cls.field_names())
        top: dict[str, Any] = {}
        nested: dict[str, dict[str, Any]] = {g: {} for g in groups}
        for k, v in values.items():
            if k not in names:
                raise LdbenchError(f"unknown parameter {k!r} for method {method!r} "
                                   f"(known: {', '.join(sorted(names)) or 'none'})")
            g, _, sub = k.partition(".")
            if sub:
                nested[g][sub] = v
            else:
                top[k] = v
        return cls(**top, **{g: d for g, d in nested.items() if d})

    def to_dict(self) -> dict:
        """Flat: every parameter by name, a grouped one as ``group.name``."""
        out = {}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if "group" in f.metadata:
                out.update({f"{f.name}.{n}": getattr(v, n) for n in _exposed(f)})
            else:
                out[f.name] = v
        return out

    @classmethod
    def field_names(cls) -> tuple:
        out = []
        for f in dataclasses.fields(cls):
            out += [f"{f.name}.{n}" for n in _exposed(f)] if "group" in f.metadata else [f.name]
        return tuple(out)


def _exposed(f) -> tuple:
    """The parameter names a group field ``f`` lets a suite set."""
    md = f.metadata
    return tuple(md["expose"]) if md["expose"] is not None else tuple(g.name for g in dataclasses.fields(md["group"]))


def _coerce(kind, v, name):
    """``v`` as the declared type ``kind``, strictly: a bool only from a bool (or the text true/false
    of a command line), an int from an integer (not a bool) or integral text, a float from an int or
    float (not a bool) or numeric text (``inf``), a str from a str. Anything else is an error naming
    the parameter, never a silent conversion (``directions = true`` is not 1)."""
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
