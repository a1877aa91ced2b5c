"""The nightly regression gate (``ldbench compare``) on synthetic run directories (no GPU)."""
import math
import zlib

import numpy as np
import pytest

from ldbench.harness.compare.gate import compare_frames, compare_paths
from ldbench.harness.compare.match import canonical_params, effect_label, parse_match
from ldbench.harness.compare.render import to_markdown
from ldbench.harness.compare.stats import min_p_value, mse_from_psnr, noise_bound, time_check
from ldbench.harness.compare.verdicts import Thresholds
from ldbench.harness import records as R
from ldbench.harness.cli import main

GPU = {"device": "nvidia", "gl_renderer": "NVIDIA H100 80GB HBM3/PCIe/SSE2",
       "gl_version": "4.6.0 NVIDIA 550.54.15", "driver": "550.54.15", "cpu": "Xeon", "gpu_name": "NVIDIA H100"}
OTHER_GPU = {**GPU, "gl_renderer": "NVIDIA H200/PCIe/SSE2", "gpu_name": "NVIDIA H200"}

BENCH = [("cornell", "ldm-ao", "ao"), ("cornell", "hbao", "ao"), ("atrium", "direct-raster", "direct")]


def _row(scene, method, effect, *, run_id="r1", ms=10.0, frames=15, jitter=0.02, seed=0, psnr=30.0,
         ssim=0.95, sigma=0.002, ref_key=None, params=None, machine=GPU, status="ok", size=(64, 64),
         scene_params=None):
    rng = np.random.default_rng(seed)
    total = list(ms * (1.0 + jitter * rng.standard_normal(frames)))
    w, h = size
    base = dict(run_id=run_id, suite="nightly", commit="abc1234def", dirty=False, scene=scene,
                scene_hash="h-" + scene, triangles=100, method=method, paper="x", effect=effect,
                effect_params={"effect": effect, "d_max": "inf", "falloff": "step"} if effect == "ao"
                else {"effect": effect},
                params=params if params is not None else {"directions": 64}, width=w, height=h,
                warmup=2, **R.machine_columns(machine), ref_spp=256, ref_variant="llvm_ad_rgb",
                ref_key=ref_key or f"ref-{scene}-{effect}", status=status,
                **({"scene_params": scene_params} if scene_params is not None else {}))
    if status != "ok":
        return R.make_row(**base)
    return R.make_row(**base, **R.timing_fields({"total": total, "wall": total}),
                      memory={"heads": 1024}, psnr=psnr, ssim=ssim, flip=0.05, relmse=0.01,
                      metric_settings={"psnr": {"data_range": 1.0}, "ssim": {"data_range": 1.0},
                                       "valid_pixels": w * h},
                      ref_noise={"rms_std_of_mean": sigma, "spp": 256})


def _run(tmp_path, name, overrides=None, drop=(), extra=(), **common):
    """A run directory with one row per BENCH entry; ``overrides[(scene, method, effect)]`` = kwargs."""
    overrides = overrides or {}
    rows = []
    for i, b in enumerate(BENCH):
        if b in drop:
            continue
        kw = {"run_id": name, "seed": zlib.crc32(f"{name}-{i}".encode()) % 1000, **common, **overrides.get(b, {})}
        rows.append(_row(*b, **kw))
    rows += [_row(*b, run_id=name, **kw) for b, kw in extra]
    d = tmp_path / name
    R.write_results(rows, d)
    return d


def _cli(capsys, *argv):
    rc = main(["compare", *map(str, argv)])
    out = capsys.readouterr()
    return rc, out.out, out.err


def test_identical_configuration_passes_and_writes_markdown(tmp_path, capsys):
    base, run = _run(tmp_path, "base"), _run(tmp_path, "run")
    rc, out, err = _cli(capsys, base, run)
    assert rc == 0, out + err
    md = (run / "compare.md").read_text()
    assert "| benchmark | metric | baseline | current | change | verdict |" in md
    assert "no regression" in md and "cornell · ldm-ao · ao (step, d_max = ∞) · 64x64" in md
    assert "no regression" in out and "wrote" in out
    # results files are accepted too, and --out chooses the report file
    rc, _, _ = _cli(capsys, base / "results.parquet", run / "results.csv", "--out", tmp_path / "x" / "c.md")
    assert rc == 0 and (tmp_path / "x" / "c.md").is_file()
    # self-comparison
    rc, _, _ = _cli(capsys, base, base, "--match", "scene,method,effect")
    assert rc == 0


def test_2x_slowdown_fails_3pct_jitter_does_not(tmp_path, capsys):
    base = _run(tmp_path, "base")
    slow = _run(tmp_path, "slow", {("cornell", "ldm-ao", "ao"): {"ms": 20.0}})
    jitter = _run(tmp_path, "jitter", ms=10.3)  # 3 % slower median, every benchmark
    rc, out, _ = _cli(capsys, base, slow)
    assert rc == 1
    assert "REGRESSION" in out and "ldm-ao" in out and "[time]" in out
    comp = compare_paths(base, slow)
    (reg,) = comp.regressions
    assert reg.metric == "time" and reg.benchmark.startswith("cornell · ldm-ao")
    assert "+100" in reg.change or "+9" in reg.change  # about +100 %
    rc, out, _ = _cli(capsys, base, jitter)
    assert rc == 0, out
    # the 3 % shift may well be significant, but it is below the 10 % minimum effect
    comp = compare_paths(base, jitter)
    assert all(c.verdict in ("ok", "improved") for c in comp.checks if c.metric == "time")
    # ... and with --min-effect 0.01 it is caught
    rc, _, _ = _cli(capsys, base, jitter, "--min-effect", "0.01")
    assert rc == 1


def test_pure_timing_noise_never_fails(tmp_path):
    base = _run(tmp_path, "base", jitter=0.05)
    for i in range(5):
        run = _run(tmp_path, f"noise{i}", jitter=0.05)
        assert compare_paths(base, run).exit_code == 0


def test_too_few_frames_is_inconclusive_not_a_failure(tmp_path):
    base = _run(tmp_path, "base", frames=3)
    slow = _run(tmp_path, "slow", frames=3, ms=30.0)
    comp = compare_paths(base, slow)
    assert comp.exit_code == 0
    assert {c.verdict for c in comp.checks if c.metric == "time"} == {"inconclusive"}
    assert min_p_value(5, 5) < 0.01 < min_p_value(4, 4)


def test_psnr_drop_of_3db_fails(tmp_path, capsys):
    base = _run(tmp_path, "base", psnr=30.0)
    run = _run(tmp_path, "run", {("cornell", "hbao", "ao"): {"psnr": 27.0}}, psnr=30.0)
    rc, out, _ = _cli(capsys, base, run)
    assert rc == 1
    (reg,) = compare_paths(base, run).regressions
    assert reg.metric == "psnr" and "hbao" in reg.benchmark and "-3.00 dB" in reg.change


def test_drop_inside_reference_noise_does_not_fail(tmp_path):
    # A noisy reference (16 spp AO: sigma up to 0.125) shared by both runs: a 1.5 dB drop at 30 dB is within
    # what the reference noise can explain at 3 sigma over 4096 pixels.
    noisy = dict(sigma=0.08, psnr=30.0)
    base = _run(tmp_path, "base", **noisy)
    run = _run(tmp_path, "run", {("cornell", "ldm-ao", "ao"): {"psnr": 28.5}}, **noisy)
    comp = compare_paths(base, run)
    assert comp.exit_code == 0, to_markdown(comp)
    chk = next(c for c in comp.checks if c.metric == "psnr" and "ldm-ao" in c.benchmark)
    assert chk.verdict == "ok" and "-1.50 dB" in chk.change
    # the same drop with a clean reference fails
    clean = dict(sigma=0.001, psnr=30.0)
    base = _run(tmp_path, "base-clean", **clean)
    run = _run(tmp_path, "run-clean", {("cornell", "ldm-ao", "ao"): {"psnr": 28.5}}, **clean)
    assert compare_paths(base, run).exit_code == 1
    # a small drop (0.3 dB) is inside the fixed tolerance
    run = _run(tmp_path, "run-small", {("cornell", "ldm-ao", "ao"): {"psnr": 29.7, "ssim": 0.945}}, **clean)
    assert compare_paths(base, run).exit_code == 0


def test_noisier_reference_in_run_explains_the_drop(tmp_path):
    # base reference sigma 0.01 (MSE 1e-3 at 30 dB); run re-rendered the reference at fewer spp
    # (sigma 0.03): the noise floor alone adds 0.03^2 - 0.01^2 = 8e-4 -> 30 dB becomes ~27.4 dB.
    base = _run(tmp_path, "base", sigma=0.01, psnr=30.0)
    run = _run(tmp_path, "run", {("cornell", "ldm-ao", "ao"): {"psnr": 27.6, "sigma": 0.03, "ref_key": "other"}},
               sigma=0.01, psnr=30.0)
    comp = compare_paths(base, run)
    assert comp.exit_code == 0, to_markdown(comp)
    chk = next(c for c in comp.checks if c.metric == "psnr" and "ldm-ao" in c.benchmark)
    assert "references differ" in chk.note


def test_noise_bound_formulas():
    # same reference: 2 z sigma (rmse_b + rmse_r) / sqrt(N)
    B = noise_bound(sigma_b=0.02, sigma_r=0.02, rmse_b=0.03, rmse_r=0.04, n=4096, same_reference=True, z=3)
    assert B == pytest.approx(2 * 3 * 0.02 * 0.07 / 64)
    # different references add the floor difference and its fluctuation
    B2 = noise_bound(sigma_b=0.01, sigma_r=0.03, rmse_b=0.03, rmse_r=0.04, n=4096, same_reference=False, z=3)
    assert B2 == pytest.approx(0.03 ** 2 - 0.01 ** 2 + 6 * (0.01 * 0.03 + 0.03 * 0.04) / 64
                               + 3 * math.sqrt(2 / 4096) * (0.01 ** 2 + 0.03 ** 2))
    # a less noisy run reference cannot fake a regression: no floor term
    B3 = noise_bound(sigma_b=0.03, sigma_r=0.01, rmse_b=0.03, rmse_r=0.04, n=4096, same_reference=False, z=3)
    assert B3 < 0.03 ** 2 - 0.01 ** 2
    assert mse_from_psnr(30.0, 1.0) == pytest.approx(1e-3) and mse_from_psnr(math.inf, 1.0) == 0.0


def test_ssim_drop_fails(tmp_path):
    base = _run(tmp_path, "base", ssim=0.95)
    run = _run(tmp_path, "run", {("atrium", "direct-raster", "direct"): {"ssim": 0.90}}, ssim=0.95)
    (reg,) = compare_paths(base, run).regressions
    assert reg.metric == "ssim" and "direct-raster" in reg.benchmark


def test_missing_row_fails_unless_allowed_and_new_row_is_reported(tmp_path, capsys):
    base = _run(tmp_path, "base")
    run = _run(tmp_path, "run", drop=[("cornell", "hbao", "ao")],
               extra=[(("hairball", "ldm-ao", "ao"), {})])
    rc, out, _ = _cli(capsys, base, run)
    assert rc == 1 and "MISSING" in out and "1 missing, 1 new" in out
    md = (run / "compare.md").read_text()
    assert "missing" in md and "🆕 new" in md and "hairball" in md
    rc, _, _ = _cli(capsys, base, run, "--allow-missing")
    assert rc == 0


def test_failed_row_in_run_is_a_regression(tmp_path):
    base = _run(tmp_path, "base")
    run = _run(tmp_path, "run", {("cornell", "hbao", "ao"): {"status": "error: shader failed"}})
    (reg,) = compare_paths(base, run).regressions
    assert reg.verdict == "failed" and reg.current.startswith("error")
    # a NaN PSNR (broken output) is a regression as well
    run = _run(tmp_path, "run-nan", {("cornell", "hbao", "ao"): {"psnr": math.nan}})
    assert [c.metric for c in compare_paths(base, run).regressions] == ["psnr"]


def test_machine_mismatch_disables_time_but_gates_quality(tmp_path, capsys):
    base = _run(tmp_path, "base")
    slow_other = _run(tmp_path, "other", {("cornell", "ldm-ao", "ao"): {"ms": 40.0}}, machine=OTHER_GPU)
    rc, out, err = _cli(capsys, base, slow_other)
    assert rc == 0, out
    assert err.count("warning: machine differs") == 1 and "time checks are off" in err
    md = (slow_other / "compare.md").read_text()
    assert "machine differs" in md and "⏭ skipped" in md
    both = _run(tmp_path, "other-worse", {("cornell", "ldm-ao", "ao"): {"ms": 40.0, "psnr": 26.0}},
                machine=OTHER_GPU)
    comp = compare_paths(base, both)
    assert [(c.metric, c.verdict) for c in comp.regressions] == [("psnr", "regression")]


def test_match_keys_compare_two_configurations(tmp_path, capsys):
    base = _run(tmp_path, "base", params={"directions": 64})
    fewer = _run(tmp_path, "fewer", {("cornell", "ldm-ao", "ao"): {"psnr": 25.0, "ms": 5.0}},
                 params={"directions": 16})
    # default match: the configurations differ -> every baseline row is missing
    rc, out, _ = _cli(capsys, base, fewer)
    assert rc == 1 and "3 missing, 3 new" in out
    rc, out, _ = _cli(capsys, base, fewer, "--match", "scene,method,effect")
    assert rc == 1
    comp = compare_paths(base, fewer, match=parse_match("scene,method,effect"))
    assert comp.matched == 3
    assert [(c.metric, c.verdict) for c in comp.regressions] == [("psnr", "regression")]
    assert any(c.metric == "time" and c.verdict == "improved" for c in comp.checks)
    assert any("directions 64 → 16" in n for n in comp.notes)
    assert "directions 64 → 16" in (fewer / "compare.md").read_text()


def test_bad_input_exits_2_with_one_line(tmp_path, capsys):
    base = _run(tmp_path, "base")
    empty = tmp_path / "empty"
    empty.mkdir()
    cases = [(tmp_path / "nope", base), (base, tmp_path / "nope"), (base, empty),
             (base, base, "--match", "scene,colour"), (base, base, "--alpha", "2")]
    for argv in cases:
        rc, out, err = _cli(capsys, *argv)
        assert rc == 2, argv
        assert err.startswith("ldbench: error: ") and err.count("\n") == 1, err
        assert "Traceback" not in err
    # a match key that makes rows ambiguous is bad input too
    two = _run(tmp_path, "two", extra=[(("cornell", "ldm-ao", "ao"), {"params": {"directions": 16}})])
    rc, _, err = _cli(capsys, two, two, "--match", "scene,method,effect")
    assert rc == 2 and "several rows" in err
    # an empty results table
    R.write_results([], tmp_path / "norows")
    rc, _, err = _cli(capsys, base, tmp_path / "norows")
    assert rc == 2 and "no result rows" in err


def test_software_rasterizer_times_are_not_gated_unless_asked(tmp_path, capsys):
    cpu = {"device": "cpu-software", "gl_renderer": "llvmpipe (LLVM 15.0.6, 256 bits)",
           "gl_version": "4.5 (Core Profile) Mesa 22.3.6", "driver": "Mesa 22.3.6", "cpu": "EPYC", "gpu_name": None}
    base = _run(tmp_path, "base", machine=cpu)
    slow = _run(tmp_path, "slow", {("cornell", "ldm-ao", "ao"): {"ms": 20.0}}, machine=cpu)
    rc, out, err = _cli(capsys, base, slow)
    assert rc == 0 and "cpu-software" in err and "time checks are off" in err
    rc, out, err = _cli(capsys, base, slow, "--cpu-time")
    assert rc == 1 and "[time]" in out
    worse = _run(tmp_path, "worse", {("cornell", "ldm-ao", "ao"): {"psnr": 26.0}}, machine=cpu)
    rc, out, _ = _cli(capsys, base, worse)
    assert rc == 1 and "[psnr]" in out


def test_cpu_time_on_another_cpu_is_not_compared(tmp_path, capsys):
    """On cpu-software the CPU is the device: --cpu-time compares times only on the same CPU model
    (llvmpipe's renderer string names LLVM, not the CPU); on a GPU the CPU does not matter."""
    cpu = {"device": "cpu-software", "gl_renderer": "llvmpipe (LLVM 15.0.6, 256 bits)",
           "gl_version": "4.5 (Core Profile) Mesa 22.3.6", "driver": "Mesa 22.3.6", "cpu": "EPYC", "gpu_name": None}
    base = _run(tmp_path, "base", machine=cpu)
    slow = _run(tmp_path, "slow", {("cornell", "ldm-ao", "ao"): {"ms": 20.0}}, machine={**cpu, "cpu": "Core i3"})
    rc, out, err = _cli(capsys, base, slow, "--cpu-time")
    assert rc == 0 and "machine differs (cpu: 'EPYC' → 'Core i3')" in err
    gbase = _run(tmp_path, "gbase")
    gslow = _run(tmp_path, "gslow", {("cornell", "ldm-ao", "ao"): {"ms": 20.0}}, machine={**GPU, "cpu": "Core i3"})
    rc, out, _ = _cli(capsys, gbase, gslow)
    assert rc == 1 and "[time]" in out


def test_benchmark_label_reads_effect_params(tmp_path):
    """The label's d_max comes from the one effect-parameter reader: inf stored as text, numbers as %g."""
    rows = [_row("cornell", "hbao", "ao"),
            R.make_row(**{**_row("cornell", "ldm-ao", "ao"),
                          "effect_params": {"effect": "ao", "d_max": 10.32, "falloff": "quadratic"}})]
    R.write_results(rows, tmp_path)
    labels = {r["method"]: effect_label(r) for _, r in R.read_results(tmp_path).iterrows()}
    assert labels == {"hbao": "ao (step, d_max = ∞)", "ldm-ao": "ao (quadratic, d_max = 10.32)"}


def _df(tmp_path, rows):
    """Rows as read back from a run directory (JSON columns parsed)."""
    d = tmp_path / f"t{len(list(tmp_path.iterdir()))}"
    R.write_results(rows, d)
    return R.read_results(d)


def test_degraded_rows_fail_the_gate(tmp_path):
    base = _df(tmp_path, [_row(*b, run_id="b") for b in BENCH])
    bad = _df(tmp_path, [_row(*b, run_id="r", status="degraded: 3 of 90 fragments not stored (pool overflow)"
                         if b[1] == "ldm-ao" else "ok") for b in BENCH])
    comp = compare_frames(base, bad)
    assert comp.exit_code == 1
    assert [c.verdict for c in comp.regressions] == ["degraded"] and "ldm-ao" in comp.regressions[0].benchmark


def test_earlier_method_names_match_their_adapter(tmp_path):
    base = _df(tmp_path, [_row("cornell", "ldm-ao", "ao", run_id="b")])
    run = _df(tmp_path, [_row("cornell", "ldm", "ao", run_id="r")])
    comp = compare_frames(base, run)
    assert comp.matched == 1 and comp.count("missing") == 0 and comp.exit_code == 0


def _rays_row(run_id, **metrics):
    m = {"hit_agreement": 0.976, "dist_err_p95": 0.0544, "self_hit_rate": 0.0034, **metrics}
    r = _row("cornell", "ldm", "rays", run_id=run_id, psnr=math.nan, ssim=math.nan)
    r.update(effect_params={"effect": "rays", "ray_kind": "diffuse", "rays_per_pixel": 4}, **m)
    return r


def test_ray_metrics_gated_with_their_own_tolerances(tmp_path):
    base = _df(tmp_path, [_rays_row("b")])
    same = compare_frames(base, _df(tmp_path, [_rays_row("r", hit_agreement=0.9755)]))
    assert same.exit_code == 0 and {c.metric for c in same.checks} >= {"hit_agreement", "dist_err_p95"}
    assert "rays (diffuse, rays_per_pixel = 4)" in same.checks[0].benchmark
    worse = compare_frames(base, _df(tmp_path, [_rays_row("r", hit_agreement=0.970)]))
    assert [c.metric for c in worse.regressions] == ["hit_agreement"]
    far = compare_frames(base, _df(tmp_path, [_rays_row("r", dist_err_p95=0.0610)]))  # +12 %: beyond 10 %
    assert [c.metric for c in far.regressions] == ["dist_err_p95"]
    nan = compare_frames(base, _df(tmp_path, [_rays_row("r", self_hit_rate=math.nan)]))
    assert [c.metric for c in nan.regressions] == ["self_hit_rate"]


# ---- what the gate must not miss (each check broken once on purpose, and these tests failed) ------------

def test_ray_metric_tolerance_is_the_larger_of_absolute_and_relative(tmp_path):
    """dist_err_p95 may grow by max(1e-4, 10 % of the baseline): +5 % passes, +12 % fails (the relative
    side governs); hit_agreement may drop by max(0.002, 0): 0.0015 passes, 0.0025 fails (the absolute)."""
    base = _df(tmp_path, [_rays_row("b")])
    cases = {("dist_err_p95", 0.0544 * 1.05): 0, ("dist_err_p95", 0.0544 * 1.12): 1,
             ("hit_agreement", 0.976 - 0.0015): 0, ("hit_agreement", 0.976 - 0.0025): 1}
    for (col, v), want in cases.items():
        comp = compare_frames(base, _df(tmp_path, [_rays_row("r", **{col: v})]))
        assert comp.exit_code == want, (col, v, to_markdown(comp))


def test_improved_needs_the_minimum_effect_too(tmp_path):
    """A consistent 3 % speed-up is significant (p < 0.01 with 15 + 15 frames of 0.5 % jitter) but below the
    10 % minimum effect: ``ok``, not ``improved``; 20 % faster is ``improved``. Likewise a PSNR gain
    inside the tolerance is ``ok``."""
    base = _run(tmp_path, "base", jitter=0.005)
    for ms, want in ((9.7, "ok"), (8.0, "improved")):
        run = _run(tmp_path, f"fast{ms}", jitter=0.005, ms=ms)
        comp = compare_paths(base, run)
        times = [c for c in comp.checks if c.metric == "time"]
        assert {c.verdict for c in times} == {want}, [(c.verdict, c.change) for c in times]
    t = time_check([10.0 * (1 + 0.001 * i) for i in range(15)], [9.7 * (1 + 0.001 * i) for i in range(15)],
                     Thresholds())
    assert t["p_faster"] < 0.01 and t["verdict"] == "ok", t
    run = _run(tmp_path, "sharper", {("cornell", "hbao", "ao"): {"psnr": 30.3}}, psnr=30.0)
    chk = next(c for c in compare_paths(_run(tmp_path, "b2", psnr=30.0), run).checks
               if c.metric == "psnr" and "hbao" in c.benchmark)
    assert chk.verdict == "ok", chk


def _full_params(method):
    from ldbench.methods.base import get_method
    return get_method(method).Params().to_dict()


def test_a_new_parameter_with_its_default_orphans_no_baseline_row(tmp_path, capsys, monkeypatch):
    """Rows store every parameter, defaults included. A baseline recorded before a parameter existed (its
    params lack it) still matches a run that records it at its default; so does one that recorded a
    parameter under its old name (``Params.renamed``); a parameter the adapter no longer has leaves the
    baseline row missing."""
    from ldbench.methods.base import get_method

    full = {m: _full_params(m) for _, m, _ in BENCH}
    older = {m: {k: v for k, v in p.items() if k != sorted(p)[0]} for m, p in full.items()}  # one dropped
    assert all(len(older[m]) == len(full[m]) - 1 for m in full if full[m])
    base = _run(tmp_path, "base", {b: {"params": older[b[1]]} for b in BENCH})
    run = _run(tmp_path, "run", {b: {"params": full[b[1]]} for b in BENCH})
    rc, out, err = _cli(capsys, base, run)
    assert rc == 0 and "3 matched, 0 missing, 0 new" in out, out + err
    assert "Configurations that differ" not in (run / "compare.md").read_text()
    # a non-default value still tells configurations apart
    hb = dict(full["hbao"], directions=full["hbao"]["directions"] + 4)
    other = _run(tmp_path, "other", {b: {"params": hb if b[1] == "hbao" else full[b[1]]} for b in BENCH})
    rc, out, _ = _cli(capsys, base, other)
    assert rc == 1 and "1 missing, 1 new" in out
    # an old name maps through Params.renamed
    cls = get_method("hbao").Params
    monkeypatch.setattr(cls, "renamed", {"old_directions": "directions"}, raising=False)
    renamed = {k if k != "directions" else "old_directions": v for k, v in full["hbao"].items()}
    old = _run(tmp_path, "old", {b: {"params": renamed if b[1] == "hbao" else full[b[1]]} for b in BENCH})
    rc, out, _ = _cli(capsys, old, run)
    assert rc == 0 and "3 matched, 0 missing" in out, out
    # a parameter the adapter no longer has: the configuration is gone, the row is missing
    gone = _run(tmp_path, "gone", {b: {"params": {**full[b[1]], "removed_knob": 3} if b[1] == "hbao"
                                       else full[b[1]]} for b in BENCH})
    rc, out, _ = _cli(capsys, gone, run)
    assert rc == 1 and "1 missing, 1 new" in out


def test_a_new_scene_parameter_with_its_default_orphans_no_baseline_row(tmp_path, capsys):
    """A baseline recorded before cornell had ``blocks`` (its scene_params lack it) matches a run that records
    it at its default; the empty box (blocks false) is another configuration."""
    base = _run(tmp_path, "base", {b: {"scene_params": {"subdivide": 0}} for b in BENCH if b[0] == "cornell"})
    run = _run(tmp_path, "run", {b: {"scene_params": {"subdivide": 0, "blocks": True}} for b in BENCH
                                 if b[0] == "cornell"})
    rc, out, err = _cli(capsys, base, run)
    assert rc == 0 and "3 matched, 0 missing, 0 new" in out, out + err
    empty = _run(tmp_path, "empty", {b: {"scene_params": {"subdivide": 0, "blocks": False}} for b in BENCH
                                     if b[0] == "cornell"})
    rc, out, _ = _cli(capsys, base, empty)
    assert rc == 1 and "2 missing, 2 new" in out, out


def test_a_nan_baseline_is_said_and_fails_unless_allowed(tmp_path, capsys):
    """A baseline whose PSNR and SSIM are NaN (a broken baseline) compares nothing: the check is
    ``unchecked``, a warning says so, the gate fails; ``--allow-nan-baseline`` lets it pass."""
    base = _run(tmp_path, "base", {("cornell", "hbao", "ao"): {"psnr": math.nan, "ssim": math.nan}})
    run = _run(tmp_path, "run")
    rc, out, err = _cli(capsys, base, run)
    assert rc == 1 and "UNCHECKED" in out and "hbao" in out, out
    assert "NaN quality metrics for 1 benchmark" in err and "--allow-nan-baseline" in err
    assert "❌ unchecked" in (run / "compare.md").read_text()
    rc, out, err = _cli(capsys, base, run, "--allow-nan-baseline")
    assert rc == 0 and "allowed by --allow-nan-baseline" in err, out + err
    # ray metrics: a NaN baseline with a value now is unchecked; NaN on both sides is a metric the
    # configuration leaves undefined (distances of shadow rays), unless nothing at all was compared
    b = _df(tmp_path, [_rays_row("b", hit_agreement=math.nan)])
    comp = compare_frames(b, _df(tmp_path, [_rays_row("r")]))
    assert [(c.metric, c.verdict) for c in comp.regressions] == [("hit_agreement", "unchecked")]
    b = _df(tmp_path, [_rays_row("b", dist_err_p95=math.nan)])
    assert compare_frames(b, _df(tmp_path, [_rays_row("r", dist_err_p95=math.nan)])).exit_code == 0
    cols = dict(hit_agreement=math.nan, dist_err_p95=math.nan, self_hit_rate=math.nan)
    comp = compare_frames(_df(tmp_path, [_rays_row("b", **cols)]), _df(tmp_path, [_rays_row("r", **cols)]))
    assert comp.exit_code == 1 and {c.verdict for c in comp.regressions} == {"unchecked"}


def test_an_int_stored_for_a_float_default_is_still_the_default(tmp_path, capsys):
    """A parameter recorded as 4 against the adapter's default 4.0 (or 8.0 against 8: JSON, TOML and hand-made
    rows do not keep the type) is the default: the rows match and no configuration difference is shown."""
    full = _full_params("hbao")
    assert isinstance(full["step_px"], float) and full["step_px"] == 4 and isinstance(full["directions"], int)
    as_int = dict(full, step_px=int(full["step_px"]), angle_bias=int(full["angle_bias"]),
                  directions=float(full["directions"]))
    assert canonical_params("hbao", as_int) == {}
    base = _run(tmp_path, "base", {b: {"params": full if b[1] == "hbao" else {}} for b in BENCH})
    run = _run(tmp_path, "run", {b: {"params": as_int if b[1] == "hbao" else {}} for b in BENCH})
    got = R.read_results(run).query("method == 'hbao'").iloc[0]["params"]
    assert type(got["step_px"]) is int and type(got["directions"]) is float  # the types survive the run file
    rc, out, err = _cli(capsys, base, run)
    assert rc == 0 and "3 matched, 0 missing, 0 new" in out, out + err
    assert "Configurations that differ" not in (run / "compare.md").read_text()
    # matched on fewer keys, the rows still show no parameter difference
    comp = compare_paths(base, run, match=parse_match("scene,method,effect"))
    assert comp.matched == 3 and not any("step_px" in n or "directions" in n for n in comp.notes), comp.notes
