import dataclasses
import json
import math
import shutil
import subprocess

import numpy as np
import pandas as pd
import pytest

from ldbench.harness import records as R
from ldbench.core.errors import LdbenchError


@dataclasses.dataclass(frozen=True)
class _Params:
    directions: int = 64
    resolution: int = 512


def _rows():
    raw = {"gbuffer": [1.0, 1.2, 1.1, 1.3], "build": [2.0, 2.5, 2.2, 2.1], "wall": [4.0, 4.4, 4.1, 4.2]}
    info = {"device": "nvidia", "gl_renderer": "NVIDIA H100 80GB HBM3/PCIe/SSE2",
            "gl_version": "4.6.0 NVIDIA 550.54.15", "driver": "550.54.15", "cpu": "Xeon", "gpu_name": "H100"}
    base = dict(run_id="r1", suite="nightly", commit="abc", dirty=True, scene="cornell",
                scene_hash="deadbeef", triangles=np.int64(36), paper="aalund2015", effect="ao",
                effect_params={"d_max": math.inf, "falloff": "step"}, width=64, height=48,
                warmup=3, **R.machine_columns(info))
    ok = R.make_row(**base, method="ldm-ao", params=_Params(), **R.timing_fields(raw),
                    memory={"heads": 1024, "nodes": np.int64(4096)}, counters={"fragments": 123, "overflow": 0},
                    psnr=math.inf, ssim=np.float32(0.95), flip=0.01, relmse=2e-3,
                    metric_settings={"ssim": {"win_size": 7, "data_range": 1.0}}, ref_spp=256,
                    ref_variant="llvm_ad_rgb", ref_key="k1", ref_noise={"mean_std": 0.003},
                    images={"test": "images/cornell/ldm-ao-ao.exr"})
    err = R.make_row(**base, method="hbao", params={"radius": 0.5}, status="error: shader failed")
    return [ok, err]


def _check_frame(df):
    assert list(df.columns[: len(R.COLUMNS)]) == list(R.COLUMNS)
    ok, err = df.iloc[0], df.iloc[1]
    assert ok["params"] == {"directions": 64, "resolution": 512}
    assert ok["effect_params"] == {"d_max": math.inf, "falloff": "step"}
    assert list(ok["stage_ms"]) == ["gbuffer", "build"]  # stage order kept
    assert ok["stage_ms"]["gbuffer"] == pytest.approx(1.15)
    assert ok["raw_ms"]["wall"] == [4.0, 4.4, 4.1, 4.2]
    assert ok["raw_ms"]["total"] == pytest.approx([3.0, 3.7, 3.3, 3.4])
    assert ok["total_ms"] == pytest.approx(3.35) and ok["wall_ms"] == pytest.approx(4.15)
    assert ok["memory"] == {"heads": 1024, "nodes": 4096} and ok["memory_bytes"] == 5120
    assert ok["counters"]["fragments"] == 123
    assert ok["psnr"] == math.inf and ok["ssim"] == pytest.approx(0.95)
    assert ok["metric_settings"]["ssim"]["win_size"] == 7
    assert ok["ref_noise"] == {"mean_std": 0.003} and ok["ref_spp"] == 256
    assert ok["images"]["test"].endswith(".exr")
    assert ok["dirty"] is True or ok["dirty"] == True  # noqa: E712 (pandas boolean)
    assert ok["frames"] == 4 and ok["triangles"] == 36 and ok["width"] == 64
    assert ok["device"] == "nvidia" and ok["machine"]["gl_renderer"].startswith("NVIDIA")
    assert ok["status"] == "ok" and ok["time"].endswith("+00:00")
    assert err["status"].startswith("error:") and err["params"] == {"radius": 0.5}
    assert math.isnan(err["psnr"]) and err["stage_ms"] is None and pd.isna(err["memory_bytes"])
    assert df["total_ms"].dtype == np.float64 and str(df["width"].dtype) == "Int64"


def test_round_trip_parquet_and_csv(tmp_path):
    paths = R.write_results(_rows(), tmp_path)
    assert paths["parquet"].is_file() and paths["csv"].is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results.csv", "results.parquet"]
    _check_frame(R.read_results(tmp_path / "results.parquet"))
    _check_frame(R.read_results(tmp_path / "results.csv"))
    _check_frame(R.read_results(tmp_path))  # a run dir reads the parquet file
    (tmp_path / "results.parquet").unlink()
    _check_frame(R.read_results(tmp_path))  # ... or the CSV
    # the CSV is plain: nested values are JSON text
    raw = pd.read_csv(tmp_path / "results.csv")
    for c in ("scene", "method", "effect", "width", "height", "params", "total_ms", "memory_bytes",
              "psnr", "ssim", "flip", "relmse", "device"):
        assert c in raw.columns
    assert raw.loc[0, "params"] == '{"directions": 64, "resolution": 512}'


def test_read_results_errors(tmp_path):
    with pytest.raises(LdbenchError):
        R.read_results(tmp_path)
    with pytest.raises(LdbenchError):
        R.read_results(tmp_path / "missing.parquet")


def test_make_row_types():
    row = R.make_row(width="64", psnr=None, dirty="false", memory={"a": 1, "b": 2})
    assert row["width"] == 64 and math.isnan(row["psnr"]) and row["dirty"] is False
    assert row["memory_bytes"] == 3 and row["memory"] == '{"a": 1, "b": 2}' and row["status"] == "ok"
    assert R.make_row(**row) == row  # idempotent
    with pytest.raises(LdbenchError, match="width"):
        R.make_row(width="wide")
    with pytest.raises(LdbenchError, match="counters"):
        R.make_row(counters={"x": object()})
    assert R.make_row(extra_col=5)["extra_col"] == 5


def test_int_columns_and_memory_beyond_int64_are_one_error_not_a_lost_run(tmp_path):
    """Parquet's int64 would raise OverflowError in the writer and lose every row of the run: a value outside
    it (an int column, a ``memory`` entry, their sum; ±1e30, inf, NaN, negative) is refused by make_row, one
    LdbenchError naming the column or buffer (the runner turns it into that row's error)."""
    for bad in (2 ** 63, -(2 ** 63) - 1, 1e30):
        with pytest.raises(LdbenchError, match="'rays'"):
            R.make_row(rays=bad)
    assert R.make_row(rays=2 ** 63 - 1)["rays"] == 2 ** 63 - 1
    for mem in ({"huge": 1e30}, {"huge": -1e30}, {"huge": -1}, {"huge": math.inf}, {"huge": math.nan},
                {"huge": 1.5}, {"huge": "1"}, {"huge": True}, {"a": 2 ** 62, "b": 2 ** 62}):
        with pytest.raises(LdbenchError, match="huge|sum"):
            R.make_row(memory=mem)
    R.write_results([R.make_row(memory={"a": 2 ** 62, "b": 2 ** 62 - 1})], tmp_path)
    assert R.read_results(tmp_path)["memory_bytes"][0] == 2 ** 63 - 1


@pytest.mark.parametrize("renderer, vendor, device", [
    ("llvmpipe (LLVM 15.0.6, 256 bits)", "Mesa", "cpu-software"),
    ("softpipe", "Mesa/X.org", "cpu-software"),
    ("NVIDIA H100 80GB HBM3/PCIe/SSE2", "NVIDIA Corporation", "nvidia"),
    ("AMD Radeon RX 7900 XTX (radeonsi, navi31, LLVM 15.0.7, DRM 3.54, 6.5.0)", "AMD", "gpu"),
    ("AMD Radeon", None, "gpu"),
    (None, None, None),
])
def test_device_classification(renderer, vendor, device):
    assert R.classify_device(renderer, vendor) == device
    gl = {"GL_RENDERER": renderer, "GL_VERSION": "4.5 (Core Profile) Mesa 22.3.6", "GL_VENDOR": vendor}
    info = R.machine_info(gl if renderer else None)
    assert info["device"] == device
    assert info["gl_renderer"] == renderer
    for k in ("hostname", "os", "cpu", "cpu_count", "python", "numpy", "moderngl", "mitsuba", "drjit",
              "gpu_name", "gpu_clock_sm_mhz", "gpu_clock_mem_mhz", "gpu_memory_mib", "driver"):
        assert k in info
    assert info["numpy"] == np.__version__


def test_driver_from_gl_version():
    assert R._driver_from_gl_version("4.5 (Core Profile) Mesa 22.3.6") == "Mesa 22.3.6"
    assert R._driver_from_gl_version("4.6.0 NVIDIA 550.54.15") == "NVIDIA 550.54.15"
    assert R._driver_from_gl_version(None) is None


def test_machine_key_stable_and_distinct():
    a = {"device": "nvidia", "gl_renderer": "NVIDIA H100 80GB HBM3/PCIe/SSE2", "driver": "550.54.15",
         "hostname": "a"}
    b = dict(a, hostname="b", gpu_clock_sm_mhz=1980.0)
    c = dict(a, driver="555.42.02")
    assert R.machine_key(a) == R.machine_key(b)
    assert R.machine_key(a) != R.machine_key(c)
    assert R.machine_key(a).startswith("nvidia-nvidia-h100")
    assert R.machine_key({}).startswith("unknown-unknown-")


@pytest.mark.skipif(shutil.which("git") is None, reason="git not installed")
def test_git_info(tmp_path):
    def git(*args):
        subprocess.run(["git", "-C", str(tmp_path), *args], check=True, capture_output=True)

    git("init", "-q", "-b", "trunk")
    git("config", "user.email", "t@example.com")
    git("config", "user.name", "t")
    (tmp_path / "a.txt").write_text("1")
    git("add", "a.txt")
    git("commit", "-q", "-m", "first")
    info = R.git_info(tmp_path)
    assert len(info["commit"]) == 40 and info["dirty"] is False and info["branch"] == "trunk"
    (tmp_path / "a.txt").write_text("2")
    assert R.git_info(tmp_path)["dirty"] is True
    assert R.git_columns(R.git_info(tmp_path)) == {"commit": info["commit"], "dirty": True}


def test_git_info_outside_repo(tmp_path):
    info = R.git_info(tmp_path)
    assert info == {"commit": None, "dirty": None, "branch": None}


def test_summarize_samples():
    s = R.summarize_samples([5.0, 1.0, 3.0, 2.0, 4.0])
    assert s == {"median": 3.0, "iqr": 2.0, "q1": 2.0, "q3": 4.0, "n": 5}
    s = R.summarize_samples([1.0, 2.0, 3.0, 4.0])
    assert s["median"] == 2.5 and s["q1"] == 1.75 and s["q3"] == 3.25 and s["iqr"] == 1.5 and s["n"] == 4
    e = R.summarize_samples([])
    assert e["n"] == 0 and math.isnan(e["median"])


def test_timing_fields_explicit_total():
    t = R.timing_fields({"a": [1.0, 2.0, 3.0], "total": [10.0, 20.0, 30.0]})
    assert t["total_ms"] == 20.0 and t["total_ms_iqr"] == 10.0 and math.isnan(t["wall_ms"])
    assert t["stage_ms"] == {"a": 2.0} and t["frames"] == 3


def test_params_record_the_values_used():
    """A cdi-vpl vpl_range row records the rsm and miss_range its VPLs were built with (the effect's),
    not the method's indirect-only defaults; other effects and methods keep their own."""
    from ldbench.core.effects import Effect
    from ldbench.harness.runner import _job_fields
    from ldbench.core.scenes import load_scene
    from ldbench.harness.suite import Job

    scene = load_scene("cornell")
    machine = R.machine_info({})

    def params(method, effect, **given):
        job = Job("cornell", (), method, tuple(sorted(given.items())), effect, 16, 16, 4, 0, 1)
        row = _job_fields("r", "s", {}, machine, job, scene, {}, "ok")
        return R.make_row(**row)["params"]

    vr = json.loads(params("cdi-vpl", Effect("vpl_range", rsm=32, miss_range=1.0), rsm=256))
    assert (vr["indirect.rsm"], vr["indirect.miss_range"], vr["indirect.cone_angle"]) == (32, 1.0, 45.0), vr
    ind = json.loads(params("cdi-vpl", Effect("indirect")))
    assert (ind["indirect.rsm"], ind["indirect.miss_range"]) == (256, 0.5)
    assert json.loads(params("ldi", Effect("rays", rays_per_pixel=4)))["image.rays_per_pixel"] == 0
