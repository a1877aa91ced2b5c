"""Parameter documentation generated from a ``Params`` class, as Mitsuba generates its plugin reference.

A method's or effect's parameters are documented once, in their :func:`~ldbench.core.params.param`
declarations (default, description, range or choices, the paper's value) and :func:`~ldbench.core.params.group`
declarations; :func:`markdown` renders them as a Markdown table with the presets and earlier names below it.
``ldbench methods NAME`` prints it, and docs/reference/parameters.md holds the tables of every built-in method,
effect and scene (:mod:`ldbench.harness.reference_page`).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from ldbench.core.params import PRESET_KEY

#: The columns of :func:`markdown`'s table (``paper`` only where some parameter has a paper value).
COLUMNS = ("parameter", "type", "default", "allowed", "paper", "description")
#: A declared type as a suite writes it (TOML).
TYPE_NAMES = {"bool": "bool", "int": "int", "float": "float", "str": "str", "tuple": "list", "list": "list"}


@dataclass(frozen=True)
class ParamRow:
    """One parameter as documented: its flat name (``group.name`` in a group), type, default, choices or
    bounds, the paper's value (None: none given) and description; a group's own row has ``kind == "group"``."""

    name: str
    kind: str
    default: object = None
    choices: tuple | None = None
    lo: object = None
    hi: object = None
    paper: object = None
    doc: str = ""


def param_rows(cls) -> list[ParamRow]:
    """The documented parameters of a ``Params`` class in declaration order: ungrouped ones first, then each
    group's row followed by the parameters it lets a suite set (with this class's defaults, narrower choices
    and paper values of them)."""
    top, grouped = [], []
    for f in dataclasses.fields(cls):
        md = f.metadata
        if "group" not in md:
            top.append(_row(f.name, f.default, md))
            continue
        assert f.default_factory is not dataclasses.MISSING  # group() gives every group field a factory
        gdefault, gfields = f.default_factory(), {g.name: g for g in dataclasses.fields(md["group"])}
        grouped.append(ParamRow(f"{f.name}.*", "group", doc=md["doc"]))
        exposed = md["expose"] if md["expose"] is not None else tuple(gfields)
        for n in exposed:
            grouped.append(_row(f"{f.name}.{n}", getattr(gdefault, n), gfields[n].metadata,
                                md["choices"].get(n), md["paper_values"].get(n)))
    return top + grouped


def _row(name, default, md, choices=None, paper=None) -> ParamRow:
    choices = choices if choices is not None else md.get("choices")
    return ParamRow(name, TYPE_NAMES.get(type(default).__name__, type(default).__name__), default,
                    tuple(choices) if choices is not None else None, md.get("lo"), md.get("hi"),
                    md.get("paper") if paper is None else paper, md.get("doc", ""))


def value_text(v) -> str:
    """A value as a suite writes it: ``true``, ``128``, ``0.25``, ``inf``, ``early_stop``, ``[]``."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
    if isinstance(v, (tuple, list)):
        return "[" + ", ".join(value_text(x) for x in v) + "]"
    return str(v)


def allowed_text(row: ParamRow) -> str:
    """The choices (``a`` \\| ``b``) or bounds (``≥ 0``, ``1 … 4096``) of a parameter; "" when unbounded."""
    if row.choices is not None:
        return " \\| ".join(_code(value_text(c)) for c in row.choices)
    lo, hi = (None if b is None else value_text(b) for b in (row.lo, row.hi))
    if lo is not None and hi is not None:
        return f"{lo} … {hi}"
    return f"≥ {lo}" if lo is not None else (f"≤ {hi}" if hi is not None else "")


def paper_text(row: ParamRow) -> str:
    """The paper's value: a value of the parameter's type as code, a remark (``"not published"``) as text."""
    if row.paper is None:
        return ""
    same_kind = isinstance(row.paper, bool) == isinstance(row.default, bool) and (
        isinstance(row.paper, type(row.default)) or (isinstance(row.default, float) and isinstance(row.paper, int)))
    if same_kind and (row.choices is None or row.paper in row.choices or not isinstance(row.paper, str)):
        return _code(value_text(row.paper))
    return _cell(str(row.paper))


def _code(text: str) -> str:
    return f"`{text}`"


def _cell(text: str) -> str:
    """Text safe inside a table cell: one line, no column separator."""
    return " ".join(str(text).split()).replace("|", "\\|")


def markdown(cls) -> str:
    """The parameters of ``cls`` (a ``Params`` class) as a Markdown table (:data:`COLUMNS`), then its
    presets and earlier names; "" for a class without parameters."""
    rows = param_rows(cls)
    if not rows:
        return ""
    paper = any(r.paper is not None for r in rows)
    columns = [c for c in COLUMNS if paper or c != "paper"]
    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    for r in rows:
        if r.kind == "group":
            cells = [_code(r.name), "group", "", "", "", _cell(r.doc)]
        else:
            cells = [_code(r.name), r.kind, _code(value_text(r.default)), allowed_text(r), paper_text(r), _cell(r.doc)]
        if not paper:
            del cells[4]
        lines.append("| " + " | ".join(cells) + " |")
    presets = getattr(cls, "presets", None) or {}
    if presets:
        lines += ["", f"Presets (`{PRESET_KEY} = \"NAME\"`; a parameter given beside it wins):", ""]
        for name, pre in presets.items():
            values = ", ".join(f"`{k} = {value_text(v)}`" for k, v in pre.values.items())
            lines.append(f"- `{PRESET_KEY} = \"{name}\"`: {_cell(pre.doc)}. Sets {values}.")
    renamed = getattr(cls, "renamed", None) or {}
    if renamed:
        lines += ["", "Earlier names, still accepted: " + ", ".join(f"`{k}` → `{v}`" for k, v in renamed.items())
                  + "."]
    return "\n".join(lines)
