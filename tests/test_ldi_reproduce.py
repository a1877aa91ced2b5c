"""niessner2010-table1 (ldbench/reports/reproductions/niessner2010/table1/): rows find their jobs at both scales, the
claims compare the right rows, and the one-row claims (LDI rays against the oracle's on the same rays, hit agreement,
§1's and §7's memory) hold and fail on either side of their bounds — on synthetic result rows."""
from __future__ import annotations

from ldbench.harness import records
from ldbench.reports.reproduce import (FAILS, HOLDS, NOT_MEASURABLE, NOT_MEASURED, evaluate, get_entry,
                                       scale_suite, suite_file)
from ldbench.harness.suite import load_suite

ENTRY = get_entry("niessner2010-table1")


def _row(kind, n, res, *, rpp=16, build="single_pass", prebuild=True, t=10.0, rps=1e9, oracle=4e8, agree=0.97,
         mem=40 * 2**20, device="nvidia"):
    """A grid or build row; ``mem``: the LDIs' own bytes (structure memory) and the row's memory alike."""
    ldis = {"ldi.ls.counters": 64, "ldi.ls.layers": 240, "ldi.ls.payload": mem - 304}
    return records.make_row(
        run_id="syn", suite="niessner2010-table1", scene="sibenik", method="ldi", effect="rays",
        effect_params={"effect": "rays", "ray_kind": kind, "rays_per_pixel": rpp},
        params={"directions": n, "resolution": res, "build": build, "prebuild": prebuild},
        width=512, height=512, device=device, gl_renderer="x", total_ms=t, total_ms_iqr=0.1, memory=ldis,
        rays_per_s=rps, oracle_rays_per_s=oracle, hit_agreement=agree, dist_err_p95=0.01, status="ok")


def test_rows_match_the_suite_at_both_scales(tmp_path):
    for scale in ("paper", "ci"):
        jobs = scale_suite(load_suite(suite_file(ENTRY)), ENTRY.scales[scale]).jobs
        assert len(jobs) == 18 + 3
        rows = [records.make_row(run_id="s", scene=j.scene, method=j.method, effect=j.effect.name,
                                 effect_params=j.effect.key(), params={**dict(j.params), "prebuild":
                                 dict(j.params).get("prebuild", False)}, width=j.width, height=j.height,
                                 device="nvidia", total_ms=1.0, rays_per_s=1e9, oracle_rays_per_s=1e8,
                                 hit_agreement=0.99, memory={"ldi.ls.counters": 64, "ldi.ls.layers": 240},
                                 status="ok") for j in jobs]
        records.write_results(rows, tmp_path / scale)
        res = evaluate(ENTRY, records.read_results(tmp_path / scale), scale)
        assert not [r for r in res["rows"] if r["ours_config"] == "no matching row in this run"], scale
        assert "not measured" not in {c["verdict"] for c in res["claims"]}


def test_claims_and_the_one_row_claims(tmp_path):
    rows = [_row(k, n, r, t=t) for k, t0 in (("diffuse", 30.0), ("glossy", 12.0), ("shadow", 8.0))
            for r, f in ((512, 3.0), (128, 1.0)) for n, g in ((96, 1.0), (150, 1.05), (384, 1.1 if k != "shadow" else 0.8))
            for t in (t0 * f * g,)]
    rows += [_row("diffuse", 96, 128, rpp=1, build="peel", prebuild=False, t=900.0),
             _row("diffuse", 384, 512, rpp=1, build="peel", prebuild=False, t=60000.0),
             _row("diffuse", 150, 128, rpp=1, build="peel", t=1.0, mem=12 * 2**20)]
    records.write_results(rows, tmp_path)
    df = records.read_results(tmp_path)
    v = {c["text"]: c["verdict"] for c in evaluate(ENTRY, df)["claims"]}
    assert v["diffuse: 128² LDIs are 2.3–4.5× faster than 512² (96 LDIs; published 3.2×)"] == HOLDS  # 3×
    c = next(c for c in ENTRY.claims if c.text.startswith("diffuse: 128²"))
    assert c.ratio == (round(37 / 16, 2), round(50 / 11, 2))  # Table 1's ranges: 37–50 vs 11–16 M rays/s
    fast = [_row("diffuse", 96, 512, t=45.0), _row("diffuse", 96, 128, t=30.0)]  # 1.5×: outside the window
    records.write_results(fast, tmp_path / "fast")
    v2 = {c["text"]: c["verdict"] for c in evaluate(ENTRY, records.read_results(tmp_path / "fast"))["claims"]}
    assert v2[c.text] == FAILS
    assert v["512²: glossy rays are faster than diffuse rays (150 vs 96 LDIs)"] == HOLDS
    assert v["128²: more LDIs help shadow rays (384 faster than 96)"] == HOLDS
    assert v["128²: …but not diffuse rays (384 LDIs not faster than 96)"] == HOLDS
    mem_150 = "150 LDIs of 128² take 15–60 MB"
    mem_100 = "The LDIs of the indirect-light set-up take less than 100 MB (96 LDIs of 128²)"
    faster = {k: f"{k}, 128², {n} LDIs: much faster than a common GPU ray tracer (≥ 2× Mitsuba's rays/s on the same rays)"
            for k, n in (("diffuse", 96), ("glossy", 150), ("soft shadows", 384))}
    agree = ("…and its approximate answers mostly agree with the exact ones: hit agreement ≥ 0.95 (diffuse, 128², "
             "96 LDIs)")
    assert v[mem_150] == FAILS and v[mem_100] == HOLDS  # 12 MB; 40 MB
    assert v[faster["diffuse"]] == v[faster["glossy"]] == v[faster["soft shadows"]] == v[agree] == HOLDS  # 2.5×, 0.97
    assert not [t for t in v if "about 1 s" in t or "about 23 s" in t]  # absolute build times: no verdict
    rows[3] = _row("diffuse", 96, 128, rps=1e9, oracle=6e8, agree=0.9, mem=120 * 2**20)  # 1.7×, 0.9, 120 MB
    rows[-1] = _row("diffuse", 150, 128, rpp=1, build="peel", t=1.0, mem=40 * 2**20)
    records.write_results(rows, tmp_path / "b")
    v = {c["text"]: c["verdict"] for c in evaluate(ENTRY, records.read_results(tmp_path / "b"))["claims"]}
    assert v[faster["diffuse"]] == v[agree] == v[mem_100] == FAILS and v[mem_150] == HOLDS
    records.write_results(rows[:2], tmp_path / "c")
    v = {c["text"]: c["verdict"] for c in evaluate(ENTRY, records.read_results(tmp_path / "c"))["claims"]}
    assert {v[t] for t in (mem_150, mem_100, agree, *faster.values())} == {NOT_MEASURED}
    cpu = [_row("diffuse", 96, 128, device="cpu-software")]
    records.write_results(cpu, tmp_path / "d")
    v = {c["text"]: c["verdict"] for c in evaluate(ENTRY, records.read_results(tmp_path / "d"))["claims"]}
    assert v[faster["diffuse"]] == NOT_MEASURABLE and v[agree] == v[mem_100] == HOLDS  # a rate is a time
    records.write_results([_row("diffuse", 6, 16, device="cpu-software")], tmp_path / "e")  # ci: 96 → 6, 128 → 16
    v = {c["text"]: c["verdict"] for c in evaluate(ENTRY, records.read_results(tmp_path / "e"), "ci")["claims"]}
    assert v[agree] == v[mem_100] == "not comparable at scale ci"
    assert next(c for c in ENTRY.claims if c.text == agree).ours
