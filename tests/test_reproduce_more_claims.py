"""The entries of the remaining paper claims (reports/reproductions): aalund2015-trace (§3.1 two-way query,
§4.1 early stop), and further entries below. Each claim is fed synthetic rows on both sides of its bound
(and noise straddling it where timed), through the real entry and the verdict engine; CPU times are 'not
measurable here'. That each entry runs at --scale ci is tested in tests/test_reproduce_new_claims.py."""
from __future__ import annotations

import pytest

from ldbench.harness import records
from ldbench.reports.reproduce import (FAILS, HOLDS, INCONCLUSIVE, NOT_MEASURABLE, evaluate, get_entry)

from test_reproduce_claims import _row


def _verdicts(tmp_path, key, rows, scale="paper"):
    records.write_results(rows, tmp_path)
    res = evaluate(get_entry(key), records.read_results(tmp_path), scale)
    return [c["verdict"] for c in res["claims"]]


# ---------------------------------------------------------------- aalund2015 §3.1, §4.1

TRACE = get_entry("aalund2015-trace")


@pytest.mark.parametrize("two, one, iqr, verdict", [(10.5, 10.0, 0.01, HOLDS),   # 5 % overhead
                                                     (8.0, 10.0, 0.01, HOLDS),    # faster: no overhead
                                                     (12.0, 10.0, 0.01, FAILS),   # 20 %: an overhead
                                                     (11.0, 10.0, 0.3, INCONCLUSIVE)])
def test_two_way_query_overhead_window(tmp_path, two, one, iqr, verdict):
    rows = [_row(TRACE, "query-two-way", t=two + 1, stages={"trace": two}, stage_iqr={"trace": iqr},
                 hit_agreement=0.9),
            _row(TRACE, "query-one-way", t=one + 1, stages={"trace": one}, stage_iqr={"trace": iqr},
                 hit_agreement=0.8)]
    assert _verdicts(tmp_path, "aalund2015-trace", rows)[0] == verdict


@pytest.mark.parametrize("two, one, verdict", [(0.95, 0.90, HOLDS), (0.90, 0.95, FAILS), (0.9, 0.9, FAILS)])
def test_two_way_query_accuracy(tmp_path, two, one, verdict):
    rows = [_row(TRACE, "query-two-way", t=1.0, stages={"trace": 1.0}, hit_agreement=two),
            _row(TRACE, "query-one-way", t=1.0, stages={"trace": 1.0}, hit_agreement=one)]
    assert _verdicts(tmp_path, "aalund2015-trace", rows)[1] == verdict


@pytest.mark.parametrize("early, full, iqr, verdict", [(5.0, 9.0, 0.1, HOLDS), (9.0, 5.0, 0.1, FAILS),
                                                        (5.0, 5.05, 0.1, INCONCLUSIVE)])
def test_early_stop_is_faster(tmp_path, early, full, iqr, verdict):
    rows = [_row(TRACE, "walk-early-stop", t=early + 2, iqr=iqr, stages={"ao": early}, stage_iqr={"ao": iqr}),
            _row(TRACE, "walk-full", t=full + 2, iqr=iqr, stages={"ao": full}, stage_iqr={"ao": iqr})]
    assert _verdicts(tmp_path, "aalund2015-trace", rows)[2] == verdict


def test_trace_times_on_a_cpu_are_not_measurable(tmp_path):
    rows = [_row(TRACE, rid, t=5.0, device="cpu-software", stages={"trace": 5.0, "ao": 5.0}, hit_agreement=0.9)
            for rid in ("query-two-way", "query-one-way", "walk-early-stop", "walk-full")]
    v = _verdicts(tmp_path, "aalund2015-trace", rows)
    assert v[0] == v[2] == NOT_MEASURABLE and v[1] == FAILS  # accuracy is no timing: equal fails "better"


def test_trace_rows_select_the_modes():
    m = {r["id"]: r["match"]["params"] for r in TRACE.rows}
    assert m["query-two-way"]["trace.query"] == "two_way" and m["query-one-way"]["trace.query"] == "one_way"
    assert m["walk-early-stop"]["trace.walk"] == "early_stop" and m["walk-full"]["trace.walk"] == "full"
    assert TRACE.claims[0].ratio == (0.0, 1.1)
