"""Benchmark history (``ldbench history add|plot``) and the change-point detector (no GPU)."""
import numpy as np
import pandas as pd
import pytest

from ldbench.harness import history as H
from ldbench.reports import history_plots as HP
from ldbench.harness import records as R
from ldbench.harness.cli import main

GPU = {"device": "nvidia", "gl_renderer": "NVIDIA H100 80GB HBM3/PCIe/SSE2",
       "gl_version": "4.6.0 NVIDIA 550.54.15", "driver": "550.54.15", "cpu": "Xeon", "gpu_name": "NVIDIA H100"}
LLVMPIPE = {"device": "cpu-software", "gl_renderer": "llvmpipe (LLVM 15.0.6, 256 bits)",
            "gl_version": "4.5 (Core Profile) Mesa 22.3.6", "driver": "Mesa 22.3.6", "cpu": "EPYC", "gpu_name": None}


def _write_run(d, run_id, *, day=1, ms=10.0, psnr=30.0, machine=GPU, seed=0, runner_style=False):
    """A run directory with two benchmarks. ``runner_style``: like ldbench/harness/runner.py, only the
    ``machine`` dict is given (no machine_key column)."""
    rng = np.random.default_rng(seed)
    mcols = R.machine_columns(machine)
    if runner_style:
        mcols = {k: v for k, v in mcols.items() if k != "machine_key"}
    rows = []
    for method, effect, scale in (("ldm-ao", "ao", 1.0), ("direct-raster", "direct", 0.5)):
        total = list(ms * scale * (1 + 0.02 * rng.standard_normal(9)))
        rows.append(R.make_row(
            run_id=run_id, suite="nightly", time=f"2026-01-{day:02d}T03:00:00+00:00",
            commit=f"{day:07x}abcdef", dirty=False, scene="cornell", method=method, effect=effect,
            effect_params={"effect": effect}, params={"directions": 64}, width=64, height=64,
            **mcols, **R.timing_fields({"total": total}), psnr=psnr, ssim=0.9,
            metric_settings={"psnr": {"data_range": 1.0}, "valid_pixels": 4096},
            ref_noise={"rms_std_of_mean": 0.002, "spp": 256}, ref_key="k"))
    R.write_results(rows, d)
    return d


def test_add_is_idempotent_and_one_file_per_machine(tmp_path, capsys):
    hist = tmp_path / "hist"
    r1 = _write_run(tmp_path / "r1", "run-1", day=1)
    r2 = _write_run(tmp_path / "r2", "run-2", day=2, runner_style=True)
    r3 = _write_run(tmp_path / "r3", "run-3", day=3, machine=LLVMPIPE)
    assert main(["history", "add", str(r1), "--history-dir", str(hist)]) == 0
    assert main(["history", "add", str(r1), "--history-dir", str(hist)]) == 0  # again: no duplicates
    key = R.machine_key(GPU)
    f = hist / f"{key}.parquet"
    assert sorted(p.name for p in hist.iterdir() if p.name != H.LOCK_NAME) == [f.name]
    assert len(pd.read_parquet(f)) == 2
    H.add_run(r2, hist)
    H.add_run(r2 / "results.parquet", hist)  # a results file works too
    H.add_run(r3, hist)
    hist_frames = H.load_history(hist)
    assert set(hist_frames) == {key, R.machine_key(LLVMPIPE)}
    g = hist_frames[key]
    assert len(g) == 4 and sorted(g["run_id"].unique()) == ["run-1", "run-2"]
    assert (g["machine_key"] == key).all()
    assert g.loc[0, "params"] == {"directions": 64} and len(g.loc[0, "raw_ms"]["total"]) == 9  # JSON kept
    out = capsys.readouterr().out
    assert out.count("history: 2 row(s)") == 2 and "(2 rows, 1 runs)" in out


def test_plot_writes_pngs_and_changes_md(tmp_path, capsys):
    hist = tmp_path / "hist"
    for day in range(1, 21):
        slow = day > 12  # a 50 % slow-down lands on day 13
        _write_run(tmp_path / f"r{day}", f"run-{day:02d}", day=day, ms=15.0 if slow else 10.0,
                   psnr=30.0 + 0.05 * np.sin(day), seed=day)
        H.add_run(tmp_path / f"r{day}", hist)
    out = tmp_path / "plots"
    rc = main(["history", "plot", "--history-dir", str(hist), "--out", str(out)])
    assert rc == 0
    pngs = sorted(out.rglob("*.png"))
    assert len(pngs) == 2 and all(p.stat().st_size > 1000 for p in pngs)
    assert pngs[0].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    md = (out / "changes.md").read_text()
    assert md.count("| total_ms |") == 2  # both benchmarks slowed down
    assert "run-13" in md and "+50" in md and "| psnr |" not in md
    assert "change point" in capsys.readouterr().out


def test_plot_bad_input(tmp_path, capsys):
    (tmp_path / "empty").mkdir()
    assert main(["history", "plot", "--history-dir", str(tmp_path / "empty")]) == 2
    assert main(["history", "plot", "--history-dir", str(tmp_path / "nope")]) == 2
    assert main(["history", "add", str(tmp_path / "nope"), "--history-dir", str(tmp_path / "h")]) == 2
    err = capsys.readouterr().err
    assert err.count("ldbench: error:") == 3 and "Traceback" not in err


def test_change_point_finds_injected_step():
    rng = np.random.default_rng(1)
    y = np.r_[10 + 0.3 * rng.standard_normal(15), 13 + 0.3 * rng.standard_normal(10)]
    (cp,) = H.detect_change_points(y)
    assert cp.index == 15 and cp.change == pytest.approx(0.3, abs=0.05) and cp.p < 0.01
    # two steps (up, then back down) are both found
    y2 = np.r_[y, 10 + 0.3 * rng.standard_normal(10)]
    assert [c.index for c in H.detect_change_points(y2)] == [15, 25]
    # absolute mode for PSNR, a constant (deterministic) series with one step
    q = np.r_[np.full(8, 31.2), np.full(6, 28.0)]
    (cq,) = H.detect_change_points(q, relative=False, min_effect=0.5)
    assert cq.index == 8 and cq.change == pytest.approx(-3.2)
    # NaN points (failed runs) are skipped; indices refer to the original series
    q2 = np.r_[np.full(8, 31.2), [np.nan], np.full(6, 28.0)]
    assert [c.index for c in H.detect_change_points(q2, relative=False, min_effect=0.5)] == [9]


def test_change_point_ignores_noise_and_small_shifts():
    for seed in range(20):
        rng = np.random.default_rng(seed)
        assert H.detect_change_points(10 + 0.5 * rng.standard_normal(40)) == [], seed
        # heavy-tailed noise with outlier nights
        assert H.detect_change_points(10 * np.exp(0.05 * rng.standard_t(2, 40))) == [], seed
    # a significant but small (2 %) shift is below the 10 % minimum effect
    rng = np.random.default_rng(0)
    y = np.r_[10 + 0.02 * rng.standard_normal(20), 10.2 + 0.02 * rng.standard_normal(20)]
    assert H.detect_change_points(y) == []
    assert [c.index for c in H.detect_change_points(y, min_effect=0.01)] == [20]
    assert H.detect_change_points(np.full(30, 5.0)) == [] and H.detect_change_points([1.0, 2.0]) == []


def test_rays_history_follows_hit_agreement(tmp_path):
    """A non-image effect's quality series is the first metric it gates (rays: hit agreement): a drop
    from 0.976 to 0.95 after run 8 is a change point of that series."""
    hist = tmp_path / "hist"
    rng = np.random.default_rng(3)
    for day in range(1, 17):
        total = list(10 * (1 + 0.02 * rng.standard_normal(9)))
        row = R.make_row(
            run_id=f"r{day}", suite="nightly", time=f"2026-01-{day:02d}T03:00:00+00:00", commit=f"{day:07x}abc",
            dirty=False, scene="cornell", method="ldm", effect="rays",
            effect_params={"effect": "rays", "ray_kind": "diffuse", "rays_per_pixel": 4}, params={},
            width=64, height=64, **R.machine_columns(GPU), **R.timing_fields({"total": total}),
            hit_agreement=(0.976 if day <= 8 else 0.95) + 0.0002 * rng.standard_normal())
        R.write_results([row], tmp_path / f"r{day}")
        H.add_run(tmp_path / f"r{day}", hist)
    res = HP.plot_history(hist)
    cps = [c for c in res["change_points"] if c["metric"] == "hit_agreement"]
    assert len(cps) == 1 and cps[0]["index"] == 8 and cps[0]["change"] < -0.02


def test_concurrent_adds_keep_every_run(tmp_path):
    """Four `history add` processes started together into one history directory: all exit 0 and the
    file holds all four runs (without the lock each read the file before the others wrote it)."""
    import os
    import subprocess
    import sys
    import time
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    hist, go = tmp_path / "hist", tmp_path / "go"
    runs = [_write_run(tmp_path / f"r{i}", f"run-{i}", day=i + 1) for i in range(4)]
    script = ("import os, sys, time\n"
              "from ldbench.harness.cli import main\n"
              "while not os.path.exists(sys.argv[2]): time.sleep(0.005)\n"
              "sys.exit(main(['history', 'add', sys.argv[1], '--history-dir', sys.argv[3]]))\n")
    env = dict(os.environ, PYTHONPATH=str(root))
    procs = [subprocess.Popen([sys.executable, "-c", script, str(r), str(go), str(hist)], cwd=root, env=env,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for r in runs]
    time.sleep(3)  # every process has imported pandas and waits
    go.write_text("")
    results = [(p.wait(timeout=120), p.stderr.read()) for p in procs]
    assert all(rc == 0 for rc, _ in results), results
    g = H.load_history(hist)[R.machine_key(GPU)]
    assert sorted(g["run_id"].unique()) == [f"run-{i}" for i in range(4)] and len(g) == 8
