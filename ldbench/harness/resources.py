"""Files ldbench ships beside its code: the bundled suites.

The suites live in the top-level ``suites/`` folder of a checkout; ``ldbench/harness/suites`` links to it, so
a wheel carries the same files as package data. A paper table's suite lives in the table's own folder,
``ldbench/reports/reproductions/<paper>/<table>/suite.toml`` (beside the published numbers it is compared
with), and is bundled under the table's key, ``<paper>-<table>``. :func:`suite_path` lets a user name a
bundled suite from anywhere: ``default``, ``default.toml`` or ``suites/default.toml`` (the form the docs
use) find ``ldbench/harness/suites/default.toml``, and ``aalund2015-fig8`` or ``suites/aalund2015-fig8.toml``
(where the table's suite lay before it moved) find ``.../aalund2015/fig8/suite.toml``, when no such file
exists relative to the current directory.
"""
from __future__ import annotations

from pathlib import Path

SUITES_DIR = Path(__file__).resolve().parent / "suites"
#: The paper tables, one folder each (read as files: the harness does not import the reports layer)
REPRODUCTIONS_DIR = Path(__file__).resolve().parents[1] / "reports" / "reproductions"
#: The file name of a paper table's suite in its folder
TABLE_SUITE = "suite.toml"


def table_key(paper: str, table: str) -> str:
    """The key of a paper table from its folders: ``aalund2015/fig8_real`` is ``aalund2015-fig8-real``.

    Folder names are Python identifiers, keys are hyphenated; the reproduction registry holds each entry's
    key to this, so that ``ldbench reproduce KEY`` and ``ldbench run KEY`` name the same suite."""
    return f"{paper}-{table.replace('_', '-')}"


def table_suites() -> dict[str, Path]:
    """{key: suite file} of every paper table folder (``<paper>/<table>/suite.toml``; folders whose name
    starts with ``_`` are skipped, as the registry skips them)."""
    out = {}
    for f in sorted(REPRODUCTIONS_DIR.glob(f"*/*/{TABLE_SUITE}")):
        paper, table = f.parent.parent.name, f.parent.name
        if not paper.startswith("_") and not table.startswith("_"):
            out[table_key(paper, table)] = f
    return out


def bundled_suites() -> list[str]:
    """Names of the bundled suites, sorted: the file stems of ``suites/`` and the paper tables' keys."""
    return sorted({p.stem for p in SUITES_DIR.glob("*.toml")} | set(table_suites()))


def suite_path(spec) -> Path:
    """The suite file ``spec`` names: an existing path as given, else a bundled suite.

    A bundled suite is found by its name (``default``), its file name (``default.toml``) or the
    checkout-relative path ``suites/default.toml``; a paper table's suite by the same three spellings of its
    key (``aalund2015-fig8``). Anything else is returned unchanged, so the caller reports the missing file
    under the name the user gave.
    """
    p = Path(spec)
    if p.is_file():
        return p
    parts = p.parts
    if len(parts) == 1 or (len(parts) == 2 and parts[0] == "suites"):
        name = parts[-1] if parts[-1].endswith(".toml") else f"{parts[-1]}.toml"
        cand = SUITES_DIR / name
        if cand.is_file():
            return cand
        table = table_suites().get(name.removesuffix(".toml"))
        if table is not None:
            return table
    return p
