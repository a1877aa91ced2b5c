"""One table of defaults (ldbench/harness/defaults.py) for run, reference, export and score: a reference that
``ldbench reference`` renders with its defaults is the cache entry a default ``run`` and the ``score`` of a
default ``export`` read."""
import json
import re
import tomllib
from pathlib import Path

import pytest

from ldbench.harness import defaults
from ldbench.harness.cli import build_parser, main

ROOT = Path(__file__).resolve().parents[1]
QUIET = ["--no-report", "--no-progress"]


def test_the_defaults_are_the_default_suites():
    """The default suite states the table's values: its numbers do not depend on which command made a
    reference."""
    head = tomllib.loads((ROOT / "suites" / "default.toml").read_text())["suite"]
    assert head["size"] == f"{defaults.SIZE[0]}x{defaults.SIZE[1]}" and head["spp"] == defaults.SPP
    for argv in (["reference", "--scene", "cornell", "--effect", "direct"],
                 ["export", "--scene", "cornell", "--effect", "direct", "--out", "q"],
                 ["run", "--scene", "cornell", "--method", "direct-raster", "--effect", "direct"]):
        args = build_parser().parse_args(argv)
        assert (args.size, args.spp) == (None, None), argv  # resolved from the table when the command runs


def _entries(cache: Path) -> list:
    return sorted(p.name for p in cache.iterdir())


def test_a_default_reference_is_reused_by_a_default_run_and_export(tmp_path, monkeypatch, capsys):
    """The table shrunk to a tiny size and spp (the commands read it when they run): ``reference`` renders
    once, ``run`` and ``export``-then-``score`` with no --size/--spp/--seed find that entry (same key,
    nothing new in the cache)."""
    import numpy as np

    from ldbench.core.exr import write_exr
    from ldbench.harness import records

    monkeypatch.setattr(defaults, "SIZE", (12, 10))
    monkeypatch.setattr(defaults, "SPP", 3)
    cache = tmp_path / "cache"
    monkeypatch.setenv("LDBENCH_CACHE", str(cache))
    scene_effect = ["--scene", "cornell", "--effect", "ao", "--d-max", "0.5"]  # ao: a reference's spp counts

    assert main(["reference", *scene_effect]) == 0
    out = capsys.readouterr().out
    assert " 12x10 spp=3 " in out and "cached" not in out, out
    key = re.search(r"key=(\S+)", out).group(1)
    entries = _entries(cache)
    assert any(key in e for e in entries), entries

    run = tmp_path / "run"
    assert main(["run", *scene_effect, "--method", "hbao", "--warmup", "0", "--frames", "1",
                 "--out", str(run), *QUIET]) == 0, capsys.readouterr().err
    row = records.read_results(run).iloc[0]
    assert (row["width"], row["height"], row["ref_spp"], row["seed"]) == (12, 10, 3, 0)
    assert row["ref_key"] == key and _entries(cache) == entries  # a cache hit, nothing rendered

    q = tmp_path / "q"
    assert main(["export", *scene_effect, "--out", str(q)]) == 0
    question = json.loads((q / "question.json").read_text())
    assert (question["width"], question["height"], question["spp"], question["seed"]) == (12, 10, 3, 0)
    write_exr(q / "answer.exr", {"Y": np.zeros((10, 12), np.float32)})
    scored = tmp_path / "scored"
    assert main(["score", str(scored), "--from", str(q), *QUIET]) == 0, capsys.readouterr().err
    row = records.read_results(scored).iloc[0]
    assert row["ref_key"] == key and row["ref_spp"] == 3 and _entries(cache) == entries


@pytest.mark.parametrize("argv", [["reference", "--scene", "cornell", "--effect", "direct", "--spp", "0"],
                                  ["export", "--scene", "cornell", "--effect", "direct", "--size", "2x2",
                                   "--out", "never"]])
def test_values_given_are_still_checked(argv, capsys):
    assert main(argv) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1
