"""The docs stand alone: every path they name exists in the project, and neither they nor the notes that
``ldbench reproduce`` prints name a tracker number or a place outside the project."""
import re
from pathlib import Path

import pytest

from ldbench.reports.reproduce import registry

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
TOP = ("harness", "methods", "references", "scripts", "suites", "tests", "docs")

#: [text](target): the target up to a title or the closing parenthesis
LINK = re.compile(r"\[[^\]\n]*\]\(\s*<?([^)\s>]+)")
#: a repository path: one of TOP, then folders and a file name with an extension (or a folder, "/")
REPO_PATH = re.compile(r"(?<![\w./$<-])((?:%s)/[\w./*-]*(?:\.[A-Za-z0-9]+|/))(?![\w<{])" % "|".join(TOP))
#: a test named by its node id, tests/test_x.py::test_name
NODE_ID = re.compile(r"(tests/\w+\.py)::(\w+)")
#: tracker numbers (the word issue with a number, an env var built on it, "#" and a number), places outside
#: the project, the old name of docs/design.md
FORBIDDEN = [
    (re.compile(r"\bissues?[ _-]?#?\d+", re.I), "a tracker number"),
    (re.compile(r"(?<![\w&/#])#\d{1,4}\b"), "a tracker number"),
    (re.compile(r"\.\./shared|(?<![\w-])shared[/](?:scenes|papers)\b|/work/|\.offline/"), "a path outside the project"),
    (re.compile(r"\ble[n]t\b", re.I), "a borrowed machine (say which GPU and driver)"),
    (re.compile(r"\bDESIGN\.md\b"), "the old name of docs/design.md"),
]


def _exists(rel: str, base: Path) -> bool:
    rel = rel.split("#")[0].rstrip(".,;:")
    if not rel:
        return True
    if any(c in rel for c in "*?["):
        return any(base.glob(rel))
    return (base / rel).exists()


def broken_links(path: Path) -> list[str]:
    """Relative markdown links (to the doc's folder), repository paths (to the root; in code spans, code
    blocks and prose alike) and test node ids of one doc that name nothing in the project."""
    text = path.read_text(encoding="utf-8")
    bad = []
    for target in LINK.findall(text):
        if re.match(r"[a-z][a-z0-9+.-]*:", target, re.I) or target.startswith("#"):
            continue  # a URL, mailto:, or an anchor of this page
        if not _exists(target, path.parent):
            bad.append(f"link {target}")
    for rel in REPO_PATH.findall(text):
        if not _exists(rel, ROOT):
            bad.append(f"path {rel}")
    for rel, name in NODE_ID.findall(text):
        f = ROOT / rel
        if f.is_file() and not re.search(rf"^\s*def {name}\(", f.read_text(encoding="utf-8"), re.M):
            bad.append(f"test {rel}::{name}")
    return bad


def forbidden(text: str) -> list[str]:
    return [f"{why}: {m.group(0)!r}" for rx, why in FORBIDDEN for m in rx.finditer(text)]


def _name(p: Path) -> str:
    return str(p.relative_to(ROOT))


@pytest.mark.parametrize("doc", DOCS, ids=_name)
def test_doc_paths_exist(doc):
    assert broken_links(doc) == []


@pytest.mark.parametrize("doc", DOCS, ids=_name)
def test_doc_names_nothing_outside_the_project(doc):
    assert forbidden(doc.read_text(encoding="utf-8")) == []


def test_reproduce_notes_name_nothing_outside_the_project():
    for key, entry in registry().items():
        for note in entry.notes:
            assert forbidden(note) == [], key
            for rel in REPO_PATH.findall(note):
                assert _exists(rel, ROOT), f"{key}: {rel}"


def test_the_checks_bite(tmp_path):
    """A doc with a broken link, a missing backticked path, a tracker number and a path outside the project."""
    (tmp_path / "there.md").write_text("x")
    doc = tmp_path / "doc.md"
    doc.write_text("[ok](there.md) [web](https://example.org/x.md) [anchor](#top) [gone](missing.md#a)\n"
                   "`ldbench/core/gpu.py` `tests/test_docs.py::test_the_checks_bite` `ldbench/methods/glsl/*.glsl` "
                   "`scripts/gpu/no-such-script.sh` `ldbench/methods/<name>.py` `ldbench/methods/ldi/`\n"
                   "    python scripts/gpu/gone.py OUT   # tests/test_docs.py::test_gone\n")
    assert broken_links(doc) == ["link missing.md#a", "path scripts/gpu/no-such-script.sh",
                                 "path scripts/gpu/gone.py", "test tests/test_docs.py::test_gone"]
    # spelt apart, so that a grep of the project for tracker numbers finds none here
    word, up, borrowed = "issue", "ISSUE", "le" "nt"
    assert len(forbidden(f"the goal of {word} 14; {up}11_DRY=1; see #12; {up.title()}s 10–12")) == 4
    assert len(forbidden(f"a mirror in ../{'shared'}/scenes, {'shared'}/papers/x.md, on the {borrowed} H200, "
                         f"{'DESIGN'}.md")) == 4
    assert forbidden("an NVIDIA H200 (driver 580.159.04), 4 issues found, colour #ff0000") == []
