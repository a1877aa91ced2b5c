"""Parameter docs exist once: the tables of docs/reference/parameters.md and ``ldbench methods NAME`` are
generated from the ``Params`` declarations (ldbench/core/paramdoc.py), so they cannot drift from the code, and
no module docstring keeps a hand-written copy."""
from __future__ import annotations

import ast
import dataclasses
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

from ldbench.core.effects import registry as effect_registry
from ldbench.core.errors import LdbenchError
from ldbench.core.paramdoc import markdown, param_rows
from ldbench.core.scenes import builders as scene_builders
from ldbench.core.params import ParamsBase, Preset, param
from ldbench.harness.reference_page import GENERATOR, HEADER, PAGE, TITLE, parameters_page, write_page
from ldbench.methods.base import registry as method_registry
from ldbench.methods.ldm import LdmParams, LdmTrace

ROOT = Path(__file__).resolve().parents[1]


def _cells(table: str, name: str) -> list[str]:
    """The cells of the row of parameter ``name`` in a generated table."""
    for line in table.splitlines():
        if line.startswith(f"| `{name}` |"):
            return [c.strip() for c in re.split(r"(?<!\\)\|", line)[1:-1]]
    raise AssertionError(f"no row {name!r}")


def test_the_committed_page_is_what_the_generator_writes():
    page = (ROOT / PAGE).read_text(encoding="utf-8")
    assert page.startswith(TITLE) and page.splitlines()[2] == HEADER and "do not edit" in HEADER and GENERATOR in HEADER
    assert page == parameters_page(), f"{PAGE} is out of step with the code: run {GENERATOR}"


def test_the_writer_replaces_only_its_own_page(tmp_path):
    page = tmp_path / "parameters.md"
    write_page(page)
    assert page.read_text(encoding="utf-8") == parameters_page()
    write_page(page)  # its own earlier page: replaced
    page.write_text("# my notes\n", encoding="utf-8")
    with pytest.raises(LdbenchError):
        write_page(page)
    assert page.read_text(encoding="utf-8") == "# my notes\n"


def test_the_page_holds_every_builtin_method_effect_and_scene():
    page = parameters_page()
    for name in [*method_registry(), *effect_registry(), *scene_builders()]:
        assert f"\n### `{name}`\n" in page, name


def test_a_default_shows_as_the_code_declares_it():
    """``trace.walk``'s default is the code's ``early_stop`` (a hand-written table once said ``early``)."""
    row = _cells(markdown(LdmParams), "trace.walk")
    assert row[1:4] == ["str", "`early_stop`", "`early_stop` \\| `full`"], row
    assert _cells(markdown(LdmParams), "directions")[2:5] == ["`128`", "1 … 4096", "`512`"]


def test_a_changed_default_changes_the_generated_table():
    """Drift cannot hide: the same class with another default renders another row."""
    drifted = dataclasses.make_dataclass(
        "Drifted", [("walk", str, param("full", "how far the list walk goes", choices=("early_stop", "full")))],
        bases=(LdmTrace,), frozen=True)
    assert _cells(markdown(drifted), "walk")[2] == "`full`"
    assert _cells(markdown(LdmTrace), "walk")[2] == "`early_stop`"


@dataclass(frozen=True)
class _Toy(ParamsBase):
    n: int = param(4, "a count", lo=1, hi=8, paper=6)
    big: int = param(0, "no upper bound", lo=0)
    ratio: float = param(float("inf"), "a distance (world units)")
    mode: str = param("a", "mode a | mode b", choices=("a", "b"), paper="not given")
    on: bool = param(True, "a switch")
    presets = {"fast": Preset("the fast one", {"n": 2, "on": False})}
    renamed = {"count": "n"}


def test_cells_of_each_kind():
    t = markdown(_Toy)
    assert t.splitlines()[0] == "| parameter | type | default | allowed | paper | description |"
    assert _cells(t, "n") == ["`n`", "int", "`4`", "1 … 8", "`6`", "a count"]
    assert _cells(t, "big")[3] == "≥ 0"
    assert _cells(t, "ratio")[2:4] == ["`inf`", ""]
    assert _cells(t, "mode")[3:] == ["`a` \\| `b`", "not given", "mode a \\| mode b"]  # a pipe cannot split a row
    assert _cells(t, "on")[2] == "`true`"
    assert '- `preset = "fast"`: the fast one. Sets `n = 2`, `on = false`.' in t
    assert "`count` → `n`" in t


def test_no_paper_column_without_a_paper_value():
    plain = dataclasses.make_dataclass("Plain", [("n", int, param(1, "a plain count", lo=0))], bases=(ParamsBase,),
                                       frozen=True)
    assert markdown(plain).splitlines()[0] == "| parameter | type | default | allowed | description |"
    assert _cells(markdown(plain), "n") == ["`n`", "int", "`1`", "≥ 0", "a plain count"]


def test_every_parameter_is_described():
    """The generated table is the only documentation, so every parameter says what it does."""
    missing = []
    classes = [(n, c.Params) for n, c in method_registry().items()]
    classes += [(n, s.Params) for n, s in effect_registry().items() if s.Params is not None]
    classes += [(n, b.Params) for n, b in scene_builders().items()]
    for owner, cls in classes:
        missing += [f"{owner}: {r.name}" for r in param_rows(cls) if len(r.doc.split()) < 3]
    assert not missing, missing


#: a reStructuredText or Markdown table whose header names parameters and defaults
_TABLE_HEADER = re.compile(r"^\s*\|?\s*`*parameter`*\s+\|?\s*`*default", re.I | re.M)


#: the modules whose docstrings describe parameters: the methods and the effects
_DESCRIBED = sorted(p.relative_to(ROOT).as_posix() for folder in ("ldbench/methods", "ldbench/core/effects")
                    for p in (ROOT / folder).rglob("*.py"))


@pytest.mark.parametrize("path", _DESCRIBED)
def test_no_docstring_keeps_a_parameter_table(path):
    doc = ast.get_docstring(ast.parse((ROOT / path).read_text(encoding="utf-8"))) or ""
    assert not _TABLE_HEADER.search(doc), f"{path}: a hand-written parameter table; the generated one is {PAGE}"


def test_no_doc_page_keeps_a_parameter_table():
    docs = [p for p in sorted((ROOT / "docs").rglob("*.md")) if p != ROOT / PAGE]
    bad = [p.name for p in docs if re.search(r"^\|\s*(?:method\s+)?parameter\s*\|\s*default", p.read_text("utf-8"),
                                             re.I | re.M)]
    assert not bad, f"hand-written parameter tables in {bad}; link {PAGE} instead"


def test_cli_prints_the_generated_table():
    out = subprocess.run([sys.executable, "-m", "ldbench.harness.cli", "methods", "ldm"], capture_output=True,
                         text=True)
    assert out.returncode == 0, out.stderr
    assert markdown(LdmParams) in out.stdout
