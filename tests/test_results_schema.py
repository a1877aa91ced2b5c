"""The results schema: docs/reference/results-columns.md documents every column a run writes, with the type
ldbench/harness/records.py gives it; every column survives write + read_results (Parquet and CSV) with its
nested fields decoded; every file carries the schema version."""
import json
import math
import re
from pathlib import Path

import pandas as pd
import pyarrow.parquet as pq
import pytest

import ldbench.harness
from ldbench.harness import records as R
from ldbench.harness.cli import main
from ldbench.core.errors import LdbenchError

DOC = Path(__file__).resolve().parents[1] / "docs" / "reference" / "results-columns.md"


def documented() -> list[tuple[str, str, str, str]]:
    """(column, type, unit, meaning) rows of the dictionary's Columns table, in order."""
    text = DOC.read_text(encoding="utf-8").split("## Columns", 1)[1]
    rows = []
    for line in text.splitlines():
        m = re.match(r"\| `([a-z0-9_]+)` \| (\w+) \| ([^|]+) \| (.+) \|$", line)
        if m:
            rows.append(tuple(s.strip() for s in m.groups()))
    return rows


def test_dictionary_lists_every_column_with_its_type_unit_and_meaning():
    rows = documented()
    assert [r[0] for r in rows] == list(R.COLUMNS)
    assert {r[0]: r[1] for r in rows} == R.COLUMN_TYPES
    assert all(r[2] and len(r[3]) > 10 for r in rows)
    assert R.SCHEMA_VERSION in DOC.read_text(encoding="utf-8")


# A value for every column, of its type (nested ones with nesting, non-finite numbers and order).
_VALUES = {"str": "text-{c}", "int": 7, "float": 2.5, "bool": True}


def _full_row():
    row = {}
    for i, (c, t) in enumerate(R.COLUMN_TYPES.items()):
        if t == "json":
            row[c] = {"z_first": [1, 2.5, None], "a": {"nested": c}, "inf": math.inf, "i": i}
        elif t == "str":
            row[c] = f"text-{c}"
        else:
            row[c] = _VALUES[t] + (i if t in ("int", "float") else 0)
    row["schema_version"] = R.SCHEMA_VERSION
    row["psnr"] = math.inf  # a perfect match stays infinite
    row["dirty"] = False
    return row


@pytest.mark.parametrize("name", ["results.parquet", "results.csv", None])
def test_every_column_round_trips(tmp_path, name):
    row = _full_row()
    R.write_results([row, R.make_row(run_id="r2", scene="cornell")], tmp_path)
    df = ldbench.harness.read_results(tmp_path / name if name else tmp_path)
    assert list(df.columns) == list(R.COLUMNS)
    got, empty = df.iloc[0], df.iloc[1]
    for c, t in R.COLUMN_TYPES.items():
        v = got[c]
        if t == "json":
            assert isinstance(v, dict), (c, v)
            assert v == row[c] and list(v) == list(row[c]), c  # decoded, key order kept
        elif t == "float":
            assert float(v) == row[c], c
        else:
            assert v == row[c], (c, v, row[c])
    for c, t in R.COLUMN_TYPES.items():  # missing values: None / NaN / NA, not "None" or "nan" text
        if c in ("run_id", "scene", "time", "status", "schema_version"):
            continue
        assert pd.isna(empty[c]) if t not in ("json",) else empty[c] is None, (c, empty[c])
    assert df.attrs["schema_version"] == R.SCHEMA_VERSION
    assert str(df["width"].dtype) == "Int64" and str(df["dirty"].dtype) == "boolean"
    assert df["total_ms"].dtype == "float64"


def test_parquet_metadata_and_column_carry_the_schema_version(tmp_path):
    R.write_results([R.make_row(run_id="r", scene="s")], tmp_path)
    meta = pq.read_schema(tmp_path / "results.parquet").metadata
    assert meta[b"ldbench.schema_version"].decode() == R.SCHEMA_VERSION
    raw = pd.read_csv(tmp_path / "results.csv")
    assert raw.columns[0] == "schema_version" and str(raw.loc[0, "schema_version"]) == R.SCHEMA_VERSION
    assert json.loads(pd.read_parquet(tmp_path / "results.parquet").loc[0, "images"] or "null") is None


def test_newer_major_is_refused_older_files_are_read(tmp_path):
    R.write_results([R.make_row(run_id="r", scene="s")], tmp_path)
    df = pd.read_csv(tmp_path / "results.csv", dtype=str)
    major = int(R.SCHEMA_VERSION.split(".")[0])
    df["schema_version"] = f"{major + 1}.0"
    df.to_csv(tmp_path / "newer.csv", index=False)
    with pytest.raises(LdbenchError, match="newer"):
        R.read_results(tmp_path / "newer.csv")
    df["schema_version"] = f"{major}.99"  # a later minor: more columns, same meaning
    df.to_csv(tmp_path / "minor.csv", index=False)
    assert R.read_results(tmp_path / "minor.csv").attrs["schema_version"] == f"{major}.99"
    old = pd.read_parquet(tmp_path / "results.parquet").drop(columns=["schema_version"])
    old.to_parquet(tmp_path / "old.parquet", index=False)  # before versions: no column, no metadata
    got = R.read_results(tmp_path / "old.parquet")
    assert got.attrs["schema_version"] is None and got.loc[0, "scene"] == "s"


def test_a_real_run_writes_only_documented_columns(tmp_path, capsys):
    out = tmp_path / "run"
    rc = main(["run", "--scene", "cornell", "--method", "direct-raster", "--effect", "direct", "--size", "16x16",
               "--spp", "2", "--frames", "1", "--warmup", "0", "--out", str(out), "--no-report", "--no-progress"])
    assert rc == 0, capsys.readouterr().err
    names = [r[0] for r in documented()]
    for f in ("results.parquet", "results.csv"):
        cols = list(pd.read_csv(out / f, nrows=0).columns) if f.endswith(".csv") else \
            pq.read_schema(out / f).names
        undocumented = [c for c in cols if c not in names]
        assert not undocumented, f"{f}: columns missing from docs/reference/results-columns.md: {undocumented}"
        assert cols[: len(names)] == names
    df = ldbench.harness.read_results(out)
    assert isinstance(df.loc[0, "stage_ms"], dict) and isinstance(df.loc[0, "machine"], dict)
    assert df.loc[0, "schema_version"] == R.SCHEMA_VERSION
