"""One place for each rule: the device class, file names and keys, effect parameters."""
import json
import math

import pandas as pd
import pytest

from ldbench.core import device, gpu
from ldbench.reports.figures.table import prepare
from ldbench.harness import records
from ldbench.harness.naming import key_slug, slug


@pytest.mark.parametrize("renderer, vendor, expected", [
    # the software rasterizers: Mesa, Apple, Google, Microsoft (the earlier records rule missed Apple's,
    # SwiftShader and WARP and recorded them as "gpu" while the timing code used wall clock)
    ("llvmpipe (LLVM 19.1.7, 256 bits)", "Mesa", "cpu-software"),
    ("softpipe", "Mesa/X.org", "cpu-software"),
    ("Software Rasterizer", "Mesa Project", "cpu-software"),
    ("Apple Software Renderer", "Apple Inc.", "cpu-software"),
    ("Google SwiftShader", "Google Inc.", "cpu-software"),
    ("Microsoft Basic Render Driver", "Microsoft Corporation", "cpu-software"),
    ("GDI Generic", "Microsoft Corporation", "cpu-software"),
    # what rasterizes decides: Mesa's llvmpipe on a machine whose vendor string says NVIDIA is the CPU
    ("llvmpipe (LLVM 15.0.6, 256 bits)", "NVIDIA Corporation", "cpu-software"),
    ("NVIDIA H200/PCIe/SSE2", "NVIDIA Corporation", "nvidia"),
    ("zink Vulkan 1.3(NVIDIA H100 80GB HBM3 (NVIDIA_PROPRIETARY))", "Mesa", "nvidia"),
    ("AMD Radeon RX 7900 XTX (radeonsi, navi31, LLVM 15.0.7, DRM 3.54)", "AMD", "gpu"),
    ("Mesa Intel(R) UHD Graphics 630 (CFL GT2)", "Intel", "gpu"),
    ("", "", None),
])
def test_one_device_rule_for_timing_and_records(renderer, vendor, expected):
    assert device.classify_device(renderer, vendor) == expected
    # the timing code (ldbench.core.gpu) and the records use this very function
    assert gpu.classify_device is device.classify_device is records.classify_device
    info = records.machine_info({"GL_RENDERER": renderer, "GL_VENDOR": vendor} if renderer else None)
    assert info["device"] == expected


def test_machine_fields_and_timing_fields():
    cols = [c for c, _ in device.MACHINE_FIELDS]
    assert set(device.TIMING_FIELDS) <= set(cols) and "cpu" in cols
    assert "cpu" not in device.timing_fields("nvidia", "nvidia")
    assert "cpu" in device.timing_fields("cpu-software", "nvidia")


@pytest.mark.parametrize("text, expected", [
    ("ldm-ao-ao-step-dinf-64x64-directions16-resolution64", "ldm-ao-ao-step-dinf-64x64-directions16-resolution64"),
    ("reference-ao-quadratic-d10.32-32x32-s1a2b3c", "reference-ao-quadratic-d10.32-32x32-s1a2b3c"),
    ("Cornell Box", "Cornell_Box"),  # case is kept
    ("cornell · ldm-ao · ao(step, d_max=inf) · 64x64", "cornell_ldm-ao_ao_step_d_max_inf_64x64"),
    ("../../escape", "escape"), ("..", "x"), (".hidden", "hidden"), ("a/b\\c", "a_b_c"), ("", "x"),
])
def test_file_name_slug(text, expected):
    assert slug(text) == expected
    assert "/" not in slug(text) and not slug(text).startswith(".")


def test_file_name_slug_length_and_fallback():
    assert slug("a" * 100, 10) == "a" * 10
    assert slug("ab" + "_" * 20 + "cd", 5) == "ab"  # no trailing "_" after cutting
    assert slug("···", fallback="benchmark") == "benchmark"


def test_key_slug_keeps_machine_keys():
    """machine_key (history file names) keeps its lower-case, '-'-separated form."""
    assert key_slug("NVIDIA H100 80GB HBM3/PCIe/SSE2", 32) == "nvidia-h100-80gb-hbm3-pcie-sse2"
    assert key_slug(None, 16) == "unknown"
    key = records.machine_key({"device": "nvidia", "gl_renderer": "NVIDIA H100 80GB HBM3/PCIe/SSE2",
                               "driver": "550.54.15"})
    assert key.startswith("nvidia-nvidia-h100-80gb-hbm3-pcie-") and len(key.rsplit("-", 1)[1]) == 8


def test_effect_param_reads_every_form_of_a_row():
    ep = {"effect": "ao", "d_max": "inf", "falloff": "quadratic"}
    for row in ({"effect_params": ep}, {"effect_params": json.dumps(ep)}, pd.Series({"effect_params": ep})):
        assert records.effect_param(row, "falloff") == "quadratic"
        assert records.effect_param(row, "missing", "dflt") == "dflt"
        assert records.effect_d_max(row) == math.inf
    assert records.effect_d_max({"effect_params": {"d_max": 0.25}}) == 0.25
    assert records.effect_d_max({"effect_params": {"effect": "direct"}}) is None
    assert records.effect_d_max({"effect_params": None}) is None
    assert records.effect_d_max({"effect_params": "not json"}) is None
    # a future effect's own parameters come through the same accessor
    assert records.effect_param({"effect_params": {"effect": "rays", "ray_kind": "shadow"}}, "ray_kind") == "shadow"


def test_figures_read_d_max_through_the_accessor(tmp_path):
    rows = [records.make_row(scene="s", method="m", effect="ao", width=4, height=4, status="ok",
                             effect_params={"effect": "ao", "d_max": d, "falloff": "step"})
            for d in ("inf", 0.5)]
    records.write_results(rows, tmp_path)
    df = prepare(records.read_results(tmp_path))
    assert list(df["d_max"]) == [math.inf, 0.5] and list(df["falloff"]) == ["step", "step"]
