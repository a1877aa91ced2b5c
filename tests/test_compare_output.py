"""``ldbench compare`` outputs: ``--md`` puts the Markdown where asked, ``--json`` writes the verdicts
for CI (per check the key, metric, values, verdict and thresholds; the exit status) as strict JSON."""
import json
import math

from ldbench.harness.compare.gate import compare_paths
from ldbench.harness.compare.match import DEFAULT_MATCH
from ldbench.harness.compare.render import JSON_FORMAT
from test_compare import _cli, _run


def _load(path):
    # strict JSON: no NaN / Infinity tokens, which jq and most CI tools refuse
    return json.loads(path.read_text(), parse_constant=lambda c: (_ for _ in ()).throw(ValueError(c)))


def test_json_verdicts_of_a_regression(tmp_path, capsys):
    base = _run(tmp_path, "base", psnr=30.0)
    run = _run(tmp_path, "run", {("cornell", "hbao", "ao"): {"psnr": 27.0}}, psnr=30.0)
    rc, out, _ = _cli(capsys, base, run, "--json", tmp_path / "ci" / "verdicts.json")
    assert rc == 1 and "verdicts.json" in out
    doc = _load(tmp_path / "ci" / "verdicts.json")
    assert doc["format"] == JSON_FORMAT and doc["exit_status"] == 1 and doc["regression"] is True
    assert doc["match"] == list(DEFAULT_MATCH) and doc["matched"] == 3
    assert doc["thresholds"]["tol_db"] == 0.5 and doc["thresholds"]["alpha"] == 0.01
    comp = compare_paths(base, run)
    assert len(doc["checks"]) == len(comp.checks)
    (reg,) = [c for c in doc["checks"] if c["regression"]]
    assert reg["metric"] == "psnr" and reg["verdict"] == "regression" and reg["column"] == "psnr"
    assert reg["baseline"] == 30.0 and reg["current"] == 27.0
    assert reg["key"]["scene"] == "cornell" and reg["key"]["method"] == "hbao" and reg["key"]["effect"] == "ao"
    assert reg["key"]["width"] == 64 and reg["key"]["effect_params"]["d_max"] == "inf"
    th = reg["thresholds"]
    assert th["tol_db"] == 0.5 and th["allowed_drop_db"] >= 0.5 and 30.0 - 27.0 > th["allowed_drop_db"]
    times = [c for c in doc["checks"] if c["metric"] == "time"]
    assert times and all(c["column"] == "total_ms" and isinstance(c["baseline"], float) for c in times)
    assert all(c["thresholds"]["alpha"] == 0.01 and c["thresholds"]["min_effect"] == 0.10 for c in times)
    ssim = next(c for c in doc["checks"] if c["metric"] == "ssim")
    assert ssim["thresholds"]["allowed_drop"] >= 0.01 and ssim["verdict"] == "ok"
    assert sum(doc["counts"].values()) == len(doc["checks"]) and doc["counts"]["regression"] == 1


def test_json_of_a_clean_run_and_of_missing_rows_and_infinite_psnr(tmp_path, capsys):
    base = _run(tmp_path, "base", psnr=math.inf)
    run = _run(tmp_path, "run", psnr=math.inf, drop=[("atrium", "direct-raster", "direct")])
    rc, _, _ = _cli(capsys, base, run, "--json", tmp_path / "v.json", "--allow-missing")
    doc = _load(tmp_path / "v.json")
    assert rc == 0 and doc["exit_status"] == 0 and doc["regression"] is False
    psnr = [c for c in doc["checks"] if c["metric"] == "psnr"]
    assert psnr and all(c["baseline"] == "inf" and c["current"] == "inf" for c in psnr)
    gone = next(c for c in doc["checks"] if c["benchmark"].startswith("atrium"))
    assert gone["metric"] == "status" and gone["current"] is None and gone["baseline"] == "ok"
    assert gone["thresholds"] == {"allow_missing": True} and gone["key"]["scene"] == "atrium"


def test_md_puts_the_markdown_where_asked_and_the_default_is_unchanged(tmp_path, capsys):
    base, run = _run(tmp_path, "base"), _run(tmp_path, "run")
    rc, out, _ = _cli(capsys, base, run, "--md", tmp_path / "out" / "gate.md")
    assert rc == 0 and (tmp_path / "out" / "gate.md").is_file() and not (run / "compare.md").exists()
    assert "| benchmark | metric |" in (tmp_path / "out" / "gate.md").read_text()
    rc, _, _ = _cli(capsys, base, run)
    assert rc == 0 and (run / "compare.md").is_file()
    assert not [p for p in (tmp_path / "out").iterdir() if p.name.startswith(".")]  # no temporary left


def test_unwritable_json_path_is_one_line(tmp_path, capsys):
    base, run = _run(tmp_path, "base"), _run(tmp_path, "run")
    (tmp_path / "file").write_text("x")
    rc, _, err = _cli(capsys, base, run, "--json", tmp_path / "file" / "v.json")
    assert rc == 2 and err.strip().count("\n") == 0 and "cannot write" in err


def test_outputs_never_replace_a_file_ldbench_did_not_write(tmp_path, capsys):
    """--md and --json replace only an earlier report of their own kind: a run's results.parquet, a user's
    notes, the other kind's report, a folder or a link are refused with one line, and nothing is written
    (both outputs are checked before either is)."""
    base, run = _run(tmp_path, "base"), _run(tmp_path, "run")
    parquet = run / "results.parquet"
    before = parquet.read_bytes()
    notes = tmp_path / "notes.md"
    notes.write_text("# my notes\n")
    (tmp_path / "dir.md").mkdir()
    (tmp_path / "link.md").symlink_to(notes)
    for args in (("--md", parquet), ("--json", parquet), ("--md", notes), ("--json", notes),
                 ("--md", tmp_path / "dir.md"), ("--md", tmp_path / "link.md"),
                 ("--md", tmp_path / "ok.md", "--json", notes)):
        rc, _, err = _cli(capsys, base, run, *args)
        assert rc == 2 and err.strip().count("\n") == 0, err
        assert "ldbench did not write" in err or "not a file ldbench wrote" in err, err
    assert parquet.read_bytes() == before and notes.read_text() == "# my notes\n"
    assert not (tmp_path / "ok.md").exists()
    # its own earlier reports are replaced; one kind is not taken for the other
    for _ in range(2):
        rc, _, _ = _cli(capsys, base, run, "--md", tmp_path / "gate.md", "--json", tmp_path / "v.json")
        assert rc == 0
    rc, _, err = _cli(capsys, base, run, "--md", tmp_path / "v.json")
    assert rc == 2 and "ldbench did not write" in err
