"""The files that let others adopt and cite ldbench: LICENSE, CITATION.cff, CHANGELOG.md and the
package metadata agree with each other."""
import tomllib
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
PROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]


def test_license_is_bsd_3_clause_of_the_ldbench_authors():
    text = (ROOT / "LICENSE").read_text()
    assert text.startswith("BSD 3-Clause License") and "the ldbench authors" in text
    assert "Neither the name of the copyright holder" in text
    assert PROJECT["license"] == "BSD-3-Clause" and PROJECT["license-files"] == ["LICENSE"]
    assert not any(c.startswith("License ::") for c in PROJECT["classifiers"])  # PEP 639: the expression only
    assert PROJECT["authors"] == [{"name": "the ldbench authors"}]


def test_citation_cites_ldbench_and_lists_the_papers_and_baselines():
    cff = yaml.safe_load((ROOT / "CITATION.cff").read_text(encoding="utf-8"))
    assert cff["cff-version"] == "1.2.0" and cff["type"] == "software" and "ldbench" in cff["title"]
    assert cff["license"] == "BSD-3-Clause" and cff["version"] == PROJECT["version"]
    refs = {(r["authors"][0]["family-names"], int(r["year"])): r for r in cff["references"]}
    assert set(refs) == {("Aalund", 2015), ("Yang", 2010), ("Nießner", 2010), ("Archer", 2019),
                         ("Bavoil", 2008), ("Jimenez", 2016), ("McGuire", 2013), ("Salvi", 2014)}
    assert refs[("Aalund", 2015)]["doi"] == "10.2312/sre.20151170"
    assert [a["family-names"] for a in refs[("Archer", 2019)]["authors"]] == ["Archer", "Leach", "Knowles"]
    for r in cff["references"]:
        assert r["title"] and r["type"] in ("article", "conference-paper") and r["authors"]


def test_changelog_keeps_a_changelog():
    text = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")
    assert text.startswith("# Changelog") and "## [Unreleased]" in text
    for section in ("### Added", "### Changed", "### Fixed"):
        assert section in text
