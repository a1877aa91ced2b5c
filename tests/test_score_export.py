"""``ldbench export`` and ``ldbench score`` (ldbench/harness/export.py, ldbench/harness/score.py): a question exported,
answered outside the harness (the method run by hand, an independent numpy tracer, Mitsuba on the
exported XML) and scored gives the harness's own numbers.
"""
import json

import numpy as np
import pytest

from ldbench.harness import records
from ldbench.harness.cli import main
from ldbench.core.effects import Effect
from ldbench.harness.executors import run_jobs
from ldbench.harness.score import Question, items_from_folder, score_into_run
from ldbench.harness.suite import suite_from_dict

SIZE = 24
IMAGE_METRICS = ("psnr", "ssim", "flip", "relmse", "coverage")


def _export(tmp_path, effect, name, size=SIZE, spp=8, **kw):
    from ldbench.harness.export import export_question

    return export_question(Question("cornell", effect, size, size, spp=spp, **kw), tmp_path / name)


@pytest.fixture(scope="module")
def hbao_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("run") / "run"
    suite = suite_from_dict({"suite": {"name": "score-test", "size": f"{SIZE}x{SIZE}", "spp": 8, "warmup": 0,
                                       "frames": 1},
                             "run": [{"scene": "cornell", "effect": "ao", "d_max": 0.5, "methods": ["hbao"]}]},
                            name="score-test")
    return out, run_jobs(suite, out, progress=False, report=False)


def _render_outside(gpu, folder):
    """hbao run by hand from the exported camera (no runner): its image and mask as answer files."""
    from ldbench.core.scene import Camera
    from ldbench.core.scenes import load_scene
    from ldbench.methods.base import View
    from ldbench.methods.hbao import HBAO
    from ldbench.core.exr import write_exr

    q = json.loads((folder / "question.json").read_text())
    cam = json.loads((folder / "camera.json").read_text())
    view = View(Camera(cam["origin"], cam["target"], cam["up"], cam["fov_y"]), cam["width"], cam["height"])
    m = HBAO()
    m.setup(gpu, load_scene(q["scene"]))
    try:
        r = m.frame(view, Effect("ao", d_max=0.5)).resolve()
    finally:
        m.release()
    write_exr(folder / "answer.exr", {"Y": r.image[..., 0]})
    np.save(folder / "mask.npy", r.mask)
    (folder / "answer.json").write_text(json.dumps({"method": "hbao-outside", "method_version": "9.9",
                                                    "stage_ms": {"ao": [1.5, 2.5]}, "memory": {"buf": 1024}}))
    return r


def test_exported_rendered_outside_and_scored_equals_the_run(tmp_path, gpu, hbao_run, capsys):
    run_dir, df = hbao_run
    folder = _export(tmp_path, Effect("ao", d_max=0.5), "q")
    _render_outside(gpu, folder)
    before = records.read_results(run_dir)
    (new,) = score_into_run(items_from_folder(tmp_path), run_dir, report=True)
    after = records.read_results(run_dir)
    assert len(after) == len(before) + 1
    inside = after[after["method"] == "hbao"].iloc[0]
    outside = after[after["method"] == "hbao-outside"].iloc[0]
    for c in IMAGE_METRICS:
        assert outside[c] == pytest.approx(inside[c], abs=1e-6), c
    assert outside["device"] == "external" and outside["timing_source"] == "user"
    assert outside["total_ms"] == pytest.approx(2.0) and outside["memory_bytes"] == 1024
    assert outside["method_version"] == "9.9" and outside["ldbench_version"] == inside["ldbench_version"]
    assert outside["ref_key"] == inside["ref_key"]
    # the run's earlier rows are kept as they were, and its report is rebuilt over both
    cols = [c for c in before.columns if c not in ("stage_ms", "raw_ms")]
    assert before[cols].astype(str).equals(after[after["method"] == "hbao"][cols].reset_index(drop=True).astype(str))
    assert (run_dir / "index.html").is_file() or any(run_dir.glob("*.html"))
    # compare, history and reproduce read the joined run like any other
    assert main(["compare", str(run_dir), str(run_dir), "--out", str(tmp_path / "cmp.md")]) == 0
    assert main(["history", "add", str(run_dir), "--history-dir", str(tmp_path / "hist")]) == 0
    assert any("external" in p.name for p in (tmp_path / "hist").iterdir())  # its own machine file
    # reproduce reads it too, and refuses it: a run of another suite would leave every claim 'not measured'
    assert main(["reproduce", "aalund2015-fig8", "--from-run", str(run_dir), "--no-report", "--no-progress"]) == 2
    assert "is a run of suite 'score-test'" in capsys.readouterr().err
    # the answer's mask counts: half the pixels without a value
    mask = np.load(folder / "mask.npy")
    mask[: SIZE // 2] = False
    np.save(folder / "mask.npy", mask)
    (half,) = score_into_run(items_from_folder(folder), tmp_path / "half", report=False)
    assert half["coverage"] < inside["coverage"] - 0.2 and half["psnr"] < inside["psnr"]


def test_png_answer_with_its_transfer_curve(tmp_path, gpu, hbao_run):
    import matplotlib.image as mpimg

    from ldbench.core.metrics import to_srgb8

    run_dir, _ = hbao_run
    folder = _export(tmp_path, Effect("ao", d_max=0.5), "png")
    r = _render_outside(gpu, folder)
    (folder / "answer.exr").unlink()
    mpimg.imsave(folder / "answer.png", to_srgb8(np.repeat(r.image, 3, -1)))
    out = tmp_path / "pngrun"
    assert main(["score", str(out), "--from", str(tmp_path / "png"), "--no-report", "--no-progress"]) == 2  # no curve
    meta = json.loads((folder / "answer.json").read_text())
    (folder / "answer.json").write_text(json.dumps({**meta, "transfer": "srgb"}))
    (row,) = score_into_run(items_from_folder(tmp_path / "png"), out, report=False)
    inside = records.read_results(run_dir).query("method == 'hbao'").iloc[0]
    assert abs(row["psnr"] - inside["psnr"]) < 0.3 and row["psnr"] != inside["psnr"]  # 8-bit quantisation only


def _brute_force_t(o, d, tmax, tri):
    """Closest hit distance per ray against every triangle (float64 Möller–Trumbore), inf = miss."""
    o, d = o.astype(np.float64), d.astype(np.float64)
    a, b, c = (tri[:, i].astype(np.float64) for i in range(3))
    e1, e2 = b - a, c - a
    p = np.cross(d[:, None], e2[None])
    det = np.einsum("tk,rtk->rt", e1, p)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        s = o[:, None] - a[None]
        u = np.einsum("rtk,rtk->rt", s, p) * inv
        q = np.cross(s, e1[None])
        v = np.einsum("rk,rtk->rt", d, q) * inv
        t = np.einsum("tk,rtk->rt", e2, q) * inv
        ok = (np.abs(det) > 1e-12) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0) & (t <= tmax[:, None])
    return np.where(ok, t, np.inf).min(1)


@pytest.mark.parametrize("kind", ["diffuse", "shadow"])
def test_rays_exported_answered_by_numpy_and_scored(tmp_path, kind):
    import trimesh

    folder = _export(tmp_path, Effect("rays", ray_kind=kind, rays_per_pixel=1), "rays", size=16)
    z = np.load(folder / "batch.npz")
    mesh = trimesh.load(folder / "scene.ply", process=False)
    t = _brute_force_t(z["origin"], z["direction"], z["tmax"], np.asarray(mesh.triangles))
    if kind == "shadow":  # the answer of a shadow ray: 0 = blocked, inf = reaches the light
        t = np.where(np.isfinite(t), 0.0, np.inf)
    np.save(folder / "answer.npy", t.astype(np.float32))
    (row,) = score_into_run(items_from_folder(folder), tmp_path / "run", report=False)
    assert row["hit_agreement"] == 1.0 and row["rays"] == len(t)
    if kind == "diffuse":
        assert row["dist_err_p99"] < 1e-5
        (folder / "answer.npy").unlink()  # the same answer as CSV text (a column t; inf = miss)
        (folder / "answer.csv").write_text("t\n" + "".join(f"{x!r}\n" for x in t.astype(np.float32).tolist()))
        (csv,) = score_into_run(items_from_folder(folder), tmp_path / "run", report=False)
        assert csv["hit_agreement"] == 1.0 and csv["dist_err_p99"] == row["dist_err_p99"]
        (folder / "answer.csv").unlink()
    np.save(folder / "answer.npy", np.full(len(t), np.inf, np.float32))  # a tracer that misses everything
    (bad,) = score_into_run(items_from_folder(folder), tmp_path / "run", report=False)
    assert bad["hit_agreement"] < 0.9


def _mitsuba_render(folder, spp):
    import mitsuba as mi

    from ldbench.references.variant import choose_variant

    mi.set_variant(choose_variant())
    return np.array(mi.render(mi.load_file(str(folder / "scene.xml")), spp=spp))


def test_exported_xml_renders_the_direct_reference(tmp_path):
    from ldbench.core.scenes import load_scene
    from ldbench.references import render_reference

    folder = _export(tmp_path, Effect("direct"), "direct", size=64, spp=16)
    img = _mitsuba_render(folder, 16)
    ref = render_reference(load_scene("cornell"), Effect("direct"), width=64, height=64, spp=1, seed=0,
                           progress=False)
    diff = np.abs(img - ref.mean)[ref.mask]
    # exact inside surfaces; the film's box filter differs from a pixel-centre value only on edges
    assert np.median(diff) < 1e-4 and np.percentile(diff, 80) < 2e-3, np.percentile(diff, [50, 80, 95])
    assert abs(img[ref.mask].mean() / ref.mean[ref.mask].mean() - 1) < 0.03


def test_exported_xml_renders_the_ao_reference_within_its_noise(tmp_path):
    from ldbench.core.scenes import load_scene
    from ldbench.references import render_reference

    folder = _export(tmp_path, Effect("ao"), "ao", size=48, spp=128)
    img = _mitsuba_render(folder, 128)[..., :1]
    ref = render_reference(load_scene("cornell"), Effect("ao"), width=48, height=48, spp=128, seed=0, progress=False)
    m = ref.mask
    z = np.abs(img - ref.mean)[m] / np.sqrt(2 * ref.variance[m] + 1e-12)  # both estimates equally noisy
    assert np.median(z) < 1.0, np.median(z)  # 0.67 for two unbiased estimates of one value
    assert abs(img[m].mean() - ref.mean[m].mean()) < 0.02


def test_score_bad_input_is_one_line(tmp_path, capsys):
    folder = _export(tmp_path, Effect("ao", d_max=0.5), "bad", size=16, spp=2)
    from ldbench.core.exr import write_exr

    write_exr(folder / "answer.exr", {"Y": np.ones((8, 8), np.float32)})
    cases = [["--from", str(folder)],  # wrong size
             ["--answer", str(folder / "answer.exr")],  # no --scene/--effect
             ["--answer", str(folder / "answer.exr"), "--from", str(folder)],
             ["--answer", str(folder / "nothing.exr"), "--scene", "cornell", "--effect", "ao", "--size", "16x16"],
             ["--answer", str(folder / "answer.exr"), "--scene", "cornell", "--effect", "ao", "--size", "8x8",
              "--stage-ms", "ao=fast"],
             ["--answer", str(folder / "answer.exr"), "--scene", "cornell", "--effect", "ao", "--size", "8x8",
              "--stage-ms", "ao=1,2", "--stage-ms", "blur=1"]]
    for args in cases:
        rc = main(["score", str(tmp_path / "out"), *args, "--no-report", "--no-progress"])
        err = capsys.readouterr().err.strip()
        assert rc == 2 and len(err.splitlines()) == 1 and err.startswith("ldbench: error:"), (args, err)
    assert not (tmp_path / "out").exists()


def test_save_arrays_writes_inputs_and_both_answers(tmp_path):
    from ldbench.core.effects.rays import ray_metrics
    from ldbench.core.effects.vpl_range import range_metrics
    from ldbench.core.scenes import load_scene

    suite = suite_from_dict({"suite": {"name": "arrays", "size": "16x16", "spp": 1, "warmup": 0, "frames": 1},
                             "run": [{"scene": "cornell", "effect": "rays", "methods": ["ldm"],
                                      "effect_params": {"rays_per_pixel": 1},
                                      "params": {"ldm": {"directions": 8, "resolution": 32}}},
                                     {"scene": "cornell", "effect": "vpl_range", "methods": ["cdi-vpl"],
                                      "effect_params": {"rsm": 16}}]}, name="arrays")
    out = tmp_path / "run"
    df = run_jobs(suite, out, progress=False, report=False, save_arrays=True)
    diag = load_scene("cornell").diagonal()
    for _, row in df.iterrows():
        path = out / row["images"]["arrays"]
        z = np.load(path)  # one line, no pickle
        if row["effect"] == "rays":
            assert z["origin"].shape == (row["rays"], 3) and z["t"].shape == z["t_ref"].shape == (row["rays"],)
            m = ray_metrics(z["t"], z["t_ref"], tmax=z["tmax"], occlusion=False, diagonal=diag)
            assert m["hit_agreement"] == pytest.approx(row["hit_agreement"], abs=1e-12)
            assert m["dist_err_p95"] == pytest.approx(row["dist_err_p95"], abs=1e-12)
        else:
            assert z["range"].shape == z["range_ref"].shape == (row["vpls"],)
            assert z["ray_origin"].shape == (6 * row["vpls"], 3)
            m = range_metrics(z["range"], z["range_ref"])
            assert m["range_err_p95"] == pytest.approx(row["range_err_p95"], abs=1e-12)
    plain = run_jobs(suite, tmp_path / "plain", progress=False, report=False)
    assert "arrays" not in plain.iloc[0]["images"] and not list((tmp_path / "plain").rglob("*.npz"))


def test_vpl_ranges_exported_answered_by_numpy_and_scored(tmp_path):
    import trimesh

    folder = _export(tmp_path, Effect("vpl_range", rsm=16), "vpl", size=16)
    z = np.load(folder / "batch.npz")
    mesh = trimesh.load(folder / "scene.ply", process=False)
    t = _brute_force_t(z["ray_origin"], z["ray_direction"], z["ray_tmax"], np.asarray(mesh.triangles))
    ranges = np.minimum(t, float(z["cap"])).reshape(-1, 6)
    assert str(z["mode"]) == "mean"
    np.savez(folder / "answer.npz", range=ranges.mean(1).astype(np.float32), t=t.astype(np.float32))
    (row,) = score_into_run(items_from_folder(folder), tmp_path / "run", report=False)
    assert row["range_within_5pct"] == 1.0 and row["range_err_p95"] < 1e-5 and row["hit_agreement"] == 1.0
    np.savez(folder / "answer.npz", range=ranges.max(1).astype(np.float32))  # the wrong reduction
    (bad,) = score_into_run(items_from_folder(folder), tmp_path / "run", report=False)
    assert bad["range_within_5pct"] < 0.9
    r, t32 = ranges.mean(1).astype(np.float32), t.astype(np.float32)
    r[:2], t32[0] = (np.inf, -np.inf), -np.inf  # no meaning: no answer, counted, never ok
    np.savez(folder / "answer.npz", range=r, t=t32)
    with np.errstate(invalid="raise", over="raise", divide="raise"):
        (inf,) = score_into_run(items_from_folder(folder), tmp_path / "run", report=False)
    assert inf["status"] == "degraded: 3 non-finite answers" and inf["nonfinite"] == 3
    assert inf["range_within_5pct"] == pytest.approx(1 - 2 / len(r)) and inf["hit_agreement"] < 1.0


def test_score_one_answer_from_the_command_line(tmp_path, gpu, hbao_run, capsys):
    run_dir, _ = hbao_run
    folder = _export(tmp_path, Effect("ao", d_max=0.5), "cli")
    _render_outside(gpu, folder)
    out = tmp_path / "cli-run"
    rc = main(["score", str(out), "--answer", str(folder / "answer.exr"), "--mask", str(folder / "mask.npy"),
               "--scene", "cornell", "--effect", "ao", "--d-max", "0.5", "--size", f"{SIZE}x{SIZE}", "--spp", "8",
               "--method", "mine", "--set", "taps=8", "--stage-ms", "ao=1,3", "--stage-ms", "blur=0.5,0.5",
               "--memory", "ao=4096", "--method-commit", "abc123", "--no-report", "--no-progress"])
    assert rc == 0, capsys.readouterr().err
    row = records.read_results(out).iloc[0]
    inside = records.read_results(run_dir).query("method == 'hbao'").iloc[0]
    assert row["method"] == "mine" and row["params"] == {"taps": 8} and row["method_commit"] == "abc123"
    assert row["psnr"] == pytest.approx(inside["psnr"], abs=1e-6)
    assert row["stage_ms"] == {"ao": 2.0, "blur": 0.5} and row["memory_bytes"] == 4096
    assert row["device"] == "external" and row["timing_source"] == "user"


def test_a_second_answer_to_one_question_keeps_the_first_rows_images(tmp_path, capsys):
    """Two answers to one question, same method and parameters, scored into one run one after the other: two
    rows, each pointing at its own image files, and the first row's files are unchanged by the second."""
    folder = _export(tmp_path, Effect("ao", d_max=0.5), "q", size=8, spp=1)
    run = tmp_path / "run"
    args = ["--scene", "cornell", "--effect", "ao", "--d-max", "0.5", "--size", "8x8", "--spp", "1", "--no-report",
            "--no-progress"]
    from ldbench.core.exr import write_image

    for value in (0.25, 0.75):
        write_image(folder / "answer.exr", np.full((8, 8, 1), value, np.float32))
        assert main(["score", str(run), "--answer", str(folder / "answer.exr"), *args]) == 0, capsys.readouterr().err
        if value == 0.25:
            first = records.read_results(run).iloc[0]["images"]
            kept = (run / first["exr"]).read_bytes()
    rows = records.read_results(run)
    assert len(rows) == 2
    a, b = rows.iloc[0]["images"], rows.iloc[1]["images"]
    assert a["exr"] != b["exr"] and a["image"] != b["image"] and a["error_exr"] != b["error_exr"]
    assert (run / a["exr"]).read_bytes() == kept and (run / b["exr"]).is_file()


def _write_png(path, a):
    """A PNG written here byte by byte (no filter, one IDAT): uint8 or uint16 codes, H x W (grey) or
    H x W x 3 (RGB), so the reader under test is checked against a writer that is not its own library."""
    import struct
    import zlib

    a = np.asarray(a)
    h, w = a.shape[:2]
    depth, ctype = (16 if a.dtype == np.uint16 else 8), (0 if a.ndim == 2 else 2)
    rows = b"".join(b"\x00" + np.ascontiguousarray(a[y]).astype(">u2" if depth == 16 else "u1").tobytes()
                    for y in range(h))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, depth, ctype, 0, 0, 0))
                     + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))
    return path


def _srgb_eotf(v):
    """IEC 61966-2-1: linear = v / 12.92 for v <= 0.04045, else ((v + 0.055) / 1.055) ** 2.4."""
    v = np.asarray(v, np.float64)
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


def test_non_square_export_camera_aspect_and_rays(tmp_path):
    """A 48x32 question: the projection's aspect is W/H, ``rays.npz`` is ``primary_rays(W, H)``, and every
    pixel's exported ray projects, through the exported view and projection matrices, onto that pixel's
    centre in the documented convention (column i from the left, row j from the top)."""
    from ldbench.core.scenes import load_scene
    from ldbench.harness.export import export_question

    w, h = 48, 32
    folder = export_question(Question("cornell", Effect("ao", d_max=0.5), w, h, spp=1), tmp_path / "wide")
    q, cam = (json.loads((folder / f).read_text()) for f in ("question.json", "camera.json"))
    assert (q["width"], q["height"], cam["width"], cam["height"]) == (w, h, w, h)
    P, V = np.array(cam["projection_matrix"]), np.array(cam["view_matrix"])
    assert P[1, 1] / P[0, 0] == pytest.approx(w / h, rel=1e-12)
    z = np.load(folder / "rays.npz")
    o_ref, d_ref = load_scene("cornell").camera.primary_rays(w, h)
    assert z["direction"].shape == (w * h, 3)
    np.testing.assert_array_equal(z["direction"], d_ref.astype(np.float32))
    np.testing.assert_array_equal(z["origin"], o_ref.astype(np.float32))
    p = np.asarray(z["origin"], np.float64) + 0.5 * (cam["near"] + cam["far"]) * np.asarray(z["direction"], np.float64)
    clip = np.concatenate([p, np.ones((len(p), 1))], 1) @ (P @ V).T
    ndc = clip[:, :2] / clip[:, 3:]
    j, i = np.divmod(np.arange(w * h), w)
    np.testing.assert_allclose(ndc[:, 0], 2 * (i + 0.5) / w - 1, atol=1e-5)
    np.testing.assert_allclose(ndc[:, 1], 1 - 2 * (j + 0.5) / h, atol=1e-5)


@pytest.mark.parametrize("depth", [8, 16])
def test_png_answers_decode_the_srgb_eotf_exactly(tmp_path, depth):
    """8- and 16-bit PNG answers, grey and RGB: ``srgb`` is the piecewise sRGB EOTF (exponent 2.4) to 1e-4,
    ``linear`` is the code / (2^depth - 1), and ``png_scale`` multiplies either."""
    from ldbench.harness.score import read_image

    top = 2 ** depth - 1
    codes = np.unique(np.concatenate([np.linspace(0, top, 256).round(), np.arange(0, 16 * (top // 255) + 1)]))
    codes = codes[: (len(codes) // 8) * 8].reshape(8, -1).astype(np.uint8 if depth == 8 else np.uint16)
    v = codes / top
    rgb = np.stack([codes, codes[::-1], np.roll(codes, 3, 1)], -1)
    for name, img, channels, want in (("grey", codes, 1, v[..., None]),
                                      ("rgb", rgb, 3, np.stack([v, v[::-1], np.roll(v, 3, 1)], -1))):
        path = _write_png(tmp_path / f"{name}{depth}.png", img)
        got = read_image(path, channels, transfer="srgb")
        assert got.shape == want.shape, name
        np.testing.assert_allclose(got, _srgb_eotf(want), rtol=0, atol=1e-4, err_msg=name)
        np.testing.assert_allclose(read_image(path, channels, transfer="linear"), want, rtol=0, atol=1e-6)
        np.testing.assert_allclose(read_image(path, channels, transfer="srgb", png_scale=4.0),
                                   4 * _srgb_eotf(want), rtol=0, atol=4e-4, err_msg=name)


def test_score_png_scale_and_grey_answers_from_the_command_line(tmp_path, capsys):
    """``--png-scale`` is the value of a PNG's white: the 1-spp reference stored (16-bit linear) as ref / 4 and
    scored with --png-scale 4 is the reference. An AO answer must be grey: a PNG with R = G but B off by one
    code in one pixel is refused in one line."""
    from ldbench.core.scenes import load_scene
    from ldbench.references import render_reference

    w, h = 16, 8
    effect = Effect("ao", d_max=0.5)
    ref = render_reference(load_scene("cornell"), effect, width=w, height=h, spp=1, seed=0, progress=False)
    mean = np.asarray(ref.mean, np.float64)[..., 0]
    assert mean.max() > 0.5  # so a scale ignored would show
    png = _write_png(tmp_path / "answer.png", np.round(np.clip(mean / 4, 0, 1) * 65535).astype(np.uint16))
    q = ["--scene", "cornell", "--effect", "ao", "--d-max", "0.5", "--size", f"{w}x{h}", "--spp", "1",
         "--no-report", "--no-progress"]
    assert main(["score", str(tmp_path / "run"), "--answer", str(png), "--transfer", "linear",
                 "--png-scale", "4", *q]) == 0, capsys.readouterr().err
    row = records.read_results(tmp_path / "run").iloc[0]
    assert row["psnr"] > 80 and row["ssim"] > 0.9999, (row["psnr"], row["ssim"])
    grey = np.repeat(np.round(np.clip(mean, 0, 1) * 255).astype(np.uint8)[..., None], 3, -1)
    grey[h // 2, w // 2, 2] ^= 1  # R = G != B in one pixel, by one code
    _write_png(tmp_path / "answer.png", grey)
    capsys.readouterr()
    rc = main(["score", str(tmp_path / "run2"), "--answer", str(png), "--transfer", "srgb", *q])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1 and "grey image (R = G = B)" in err, err
    assert not (tmp_path / "run2").exists()


def _ref_answer(folder, w=16, h=16):
    """An exact answer: the question's own 1-spp reference, as answer.exr."""
    from ldbench.core.exr import write_exr
    from ldbench.core.scenes import load_scene
    from ldbench.references import render_reference

    ref = render_reference(load_scene("cornell"), Effect("ao", d_max=0.5), width=w, height=h, spp=1, seed=0,
                           progress=False)
    img = np.array(ref.mean[..., 0], np.float32)
    write_exr(folder / "answer.exr", {"Y": img})
    return img, np.asarray(ref.mask)


@pytest.mark.filterwarnings("error::RuntimeWarning")  # no numpy warning may reach stderr
def test_score_nan_and_inf_pixels_and_masks_are_failed_pixels_never_ok(tmp_path, capsys):
    """One NaN and one inf pixel: not ``ok`` but ``degraded: 2 non-finite pixels`` (exit 1), counted in
    ``nonfinite``, scored as missing pixels (finite PSNR, coverage below 1); a NaN mask is no coverage."""
    from ldbench.core.exr import write_exr

    folder = _export(tmp_path, Effect("ao", d_max=0.5), "nan", size=16, spp=1)
    img, hit = _ref_answer(folder)
    ys, xs = np.nonzero(hit & (img < 0.9))  # where a missing pixel (1, ao's background) is an error
    bad = img.copy()
    bad[ys[0], xs[0]], bad[ys[-1], xs[-1]] = np.nan, np.inf
    write_exr(folder / "answer.exr", {"Y": bad})
    rc = main(["score", str(tmp_path / "run"), "--from", str(folder), "--no-report", "--no-progress"])
    out, err = capsys.readouterr()
    assert rc == 1 and err == "", err
    assert "degraded: 2 non-finite pixels" in out
    row = records.read_results(tmp_path / "run").iloc[-1]
    assert row["status"] == "degraded: 2 non-finite pixels" and row["nonfinite"] == 2
    assert np.isfinite(row["psnr"]) and np.isfinite(row["relmse"]) and row["coverage"] == pytest.approx(
        1 - 2 / hit.sum())
    write_exr(folder / "answer.exr", {c: bad for c in "RGB"})  # grey RGB with the same NaN and inf
    (rgb,) = score_into_run(items_from_folder(folder), tmp_path / "run1", report=False)
    assert rgb["status"] == "degraded: 2 non-finite pixels" and rgb["psnr"] == row["psnr"]
    write_exr(folder / "answer.exr", {"Y": img})  # the exact answer, a mask NaN everywhere but one pixel
    mask = np.full(img.shape, np.nan, np.float32)
    mask[ys[0], xs[0]] = 1.0
    np.save(folder / "mask.npy", mask)
    (row,) = score_into_run(items_from_folder(folder), tmp_path / "run2", report=False)
    assert row["coverage"] == pytest.approx(1 / hit.sum()) and row["nonfinite"] == img.size - 1
    assert row["status"] == f"degraded: {img.size - 1} non-finite pixels"
    (folder / "mask.npy").unlink()
    (row,) = score_into_run(items_from_folder(folder), tmp_path / "run3", report=False)
    assert row["status"] == "ok" and row["nonfinite"] == 0 and row["coverage"] == 1.0


def test_score_hostile_answer_files_are_one_line(tmp_path, capsys):
    """answer.json fields of the wrong type, memory >= 1e20 (beyond int64), masks that are 0-d, 1-d, object
    arrays, strings, zero bytes or a garbage PNG, a zero-byte answer .npy: one line, exit 2, nothing written."""
    from test_cli import assert_one_line_error

    folder = _export(tmp_path, Effect("ao", d_max=0.5), "bad", size=16, spp=1)
    _ref_answer(folder)

    def refused(*needles, args=None):
        out = tmp_path / "out"
        rc = main(["score", str(out), *(args or ["--from", str(folder)]), "--no-report", "--no-progress"])
        assert_one_line_error(rc, capsys.readouterr().err, *needles)
        assert not out.exists()

    for meta, needle in (({"method": 5}, "method must be a string"), ({"paper": {}}, "paper must be a string"),
                         ({"method_version": 1.5}, "method_version"), ({"params": [1]}, "params must be a table"),
                         ({"stage_ms": [1, 2]}, "stage_ms must be a table"), ({"memory": [1]}, "memory must be"),
                         ({"memory": {"a": 1e20}}, "'a'"), ({"memory": {"a": "x"}}, "'a'"),
                         ({"memory": {"a": float("inf")}}, "'a'"), ({"memory": {"a": 2 ** 62, "b": 2 ** 62}}, "sum"),
                         ({"transfer": ["srgb"]}, "transfer"), ({"png_scale": True}, "png_scale"),
                         ({"stage_ms": {"ao": True}}, "stage time")):
        (folder / "answer.json").write_text(json.dumps(meta))
        refused(needle)
    (folder / "answer.json").unlink()
    refused("memory 'ao'", args=["--answer", str(folder / "answer.exr"), "--scene", "cornell", "--effect", "ao",
                                 "--d-max", "0.5", "--size", "16x16", "--spp", "1", "--memory", f"ao={10 ** 20}"])
    np.save(folder / "mask.npy", np.array([None, 1], dtype=object), allow_pickle=True)
    refused("cannot read mask")
    for bad in (np.float32(1), np.ones(16, np.float32), np.array([["a"] * 16] * 16)):
        np.save(folder / "mask.npy", bad)
        refused("mask")
    (folder / "mask.npy").write_bytes(b"")
    refused("cannot read mask")
    (folder / "mask.npy").unlink()
    for garbage in (b"garbage", b"\x89PNG\r\n\x1a\n" + b"\0" * 40):
        (folder / "mask.png").write_bytes(garbage)
        refused("cannot read mask")
    (folder / "mask.png").unlink()
    rays = _export(tmp_path, Effect("rays", rays_per_pixel=1), "rays", size=16)
    (rays / "answer.npy").write_bytes(b"")
    refused("cannot read", args=["--from", str(rays)])
    np.save(rays / "answer.npy", np.array(["x"] * 4))
    refused("must hold numbers", args=["--from", str(rays)])


def test_export_replaces_only_an_earlier_export_and_all_at_once(tmp_path, monkeypatch):
    """export --out follows run --out's rule (ldbench/harness/rundir.py): a user's folder (even one holding a
    scene.xml) and an export beside which an answer was saved are refused before any work, untouched; an
    earlier export is replaced whole (no batch.npz of the previous question left), and an export that fails
    halfway leaves the previous one as it was, with no temporary folder."""
    from ldbench.core.errors import LdbenchError
    from ldbench.harness import export

    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "scene.xml").write_text("<scene version='3.0.0'/>")
    with pytest.raises(LdbenchError, match="not an ldbench question"):
        _export(tmp_path, Effect("ao", d_max=0.5), "mine", size=8, spp=1)
    assert [p.name for p in mine.iterdir()] == ["scene.xml"]
    q = _export(tmp_path, Effect("rays", ray_kind="diffuse", rays_per_pixel=1), "q", size=8, spp=1)
    assert (q / "batch.npz").is_file()
    first = (q / "question.json").read_text()
    again = _export(tmp_path, Effect("ao", d_max=0.5), "q", size=8, spp=1)
    assert again == q and not (q / "batch.npz").exists() and (q / "question.json").read_text() != first
    second = (q / "question.json").read_text()

    def broken(question, scene, out):
        (out / "question.json").write_text("{}")
        raise RuntimeError("disk full")

    monkeypatch.setattr(export, "_write_question", broken)
    with pytest.raises(RuntimeError):
        _export(tmp_path, Effect("direct"), "q", size=8, spp=1)
    assert (q / "question.json").read_text() == second
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine", "q"]  # no partial folder, no lock
    monkeypatch.undo()
    np.save(q / "answer.npy", np.zeros(3, np.float32))
    with pytest.raises(LdbenchError, match="did not write.*answer.npy"):
        _export(tmp_path, Effect("ao", d_max=0.5), "q", size=8, spp=1)
    assert (q / "answer.npy").is_file() and (q / "question.json").read_text() == second


@pytest.mark.filterwarnings("error::RuntimeWarning")
def test_score_rays_minus_inf_is_a_non_finite_answer(tmp_path):
    """Per-ray answers: inf is a miss and NaN no answer (counted wrong, still ``ok``); -inf means nothing: it
    counts as no answer, in ``nonfinite``, and the row is ``degraded: N non-finite answers``."""
    folder = _export(tmp_path, Effect("rays", rays_per_pixel=1), "rays", size=16)
    n = len(np.load(folder / "batch.npz")["tmax"])
    t = np.full(n, np.inf, np.float32)
    t[:3] = np.nan
    np.save(folder / "answer.npy", t)
    (row,) = score_into_run(items_from_folder(folder), tmp_path / "run", report=False)
    assert row["status"] == "ok" and row["nonfinite"] == 0 and row["coverage"] == pytest.approx(1 - 3 / n)
    t[3:5] = -np.inf
    np.save(folder / "answer.npy", t)
    (row,) = score_into_run(items_from_folder(folder), tmp_path / "run", report=False)
    assert row["status"] == "degraded: 2 non-finite answers" and row["nonfinite"] == 2
    assert row["coverage"] == pytest.approx(1 - 5 / n)


def test_ctrl_c_while_score_writes_its_report_says_the_rows_are_kept(tmp_path, capsys, monkeypatch):
    """The rows are committed before the report: Ctrl-C then exits 130 saying they are kept and how to write
    the report, so that nobody scores them a second time."""
    from ldbench.core.exr import write_image
    from ldbench.reports import report

    folder = _export(tmp_path, Effect("ao", d_max=0.5), "q", size=8, spp=1)
    write_image(folder / "answer.exr", np.full((8, 8, 1), 0.5, np.float32))

    def interrupt(run_dir):
        raise KeyboardInterrupt

    monkeypatch.setattr(report, "write_report", interrupt)
    run = tmp_path / "run"
    rc = main(["score", str(run), "--answer", str(folder / "answer.exr"), "--scene", "cornell", "--effect", "ao",
               "--d-max", "0.5", "--size", "8x8", "--spp", "1", "--no-progress"])
    err = capsys.readouterr().err
    assert rc == 130 and "are kept in" in err and f"ldbench report {run}" in err, err
    assert len(records.read_results(run)) == 1


def _png_bytes(w, h, depth, ctype, rows, plte=b""):
    """A PNG of pre-packed ``rows`` (bytes each, no filter byte yet), with a PLTE chunk when given."""
    import struct
    import zlib

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    raw = b"".join(b"\x00" + r for r in rows)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, depth, ctype, 0, 0, 0))
            + (chunk(b"PLTE", plte) if plte else b"") + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


@pytest.mark.parametrize("kind", ["grey1", "grey2", "grey4", "grey-alpha8", "grey-alpha16", "rgba8", "rgba16",
                                  "palette8", "palette4"])
def test_every_png_mode_reads_as_its_codes_in_float(tmp_path, kind):
    """Every PNG colour type and bit depth the reader accepts answers with its codes / (2^depth − 1) (a palette
    with its entries / 255), alpha dropped, against the same image in float: packed 1-, 2- and 4-bit grey,
    grey + alpha and RGBA at 8 and 16 bits (Pillow keeps only the high byte of 16-bit colour), 8- and 4-bit
    palettes. The files are packed here byte by byte, not by the reader's library."""
    from ldbench.harness.score import read_image

    rng = np.random.default_rng(7)
    w, h = 12, 5
    if kind.startswith("grey") and "alpha" not in kind:
        depth = int(kind[4:])
        codes = rng.integers(0, 2 ** depth, (h, w))
        per = 8 // depth
        rows = [bytes(sum(int(c) << (8 - depth * (i + 1)) for i, c in enumerate(r[k:k + per]))
                      for k in range(0, w, per)) for r in codes]
        data, want = _png_bytes(w, h, depth, 0, rows), (codes / (2 ** depth - 1))[..., None]
        channels = 1
    elif kind.startswith("palette"):
        depth = int(kind[7:])
        pal = rng.integers(0, 256, (2 ** depth, 3))
        idx = rng.integers(0, 2 ** depth, (h, w))
        per = 8 // depth
        rows = [bytes(sum(int(c) << (8 - depth * (i + 1)) for i, c in enumerate(r[k:k + per]))
                      for k in range(0, w, per)) for r in idx]
        data, want = _png_bytes(w, h, depth, 3, rows, plte=pal.astype(np.uint8).tobytes()), pal[idx] / 255.0
        channels = 3
    else:
        depth = int(kind[-2:] if kind.endswith("16") else kind[-1])
        n, ctype = (2, 4) if kind.startswith("grey") else (4, 6)
        codes = rng.integers(0, 2 ** depth, (h, w, n))
        codes[0, 0, :n - 1] = 2 ** depth - 1 - 1  # a code whose low byte matters at 16 bits
        dt = ">u2" if depth == 16 else "u1"
        rows = [codes[y].astype(dt).tobytes() for y in range(h)]
        data, want = _png_bytes(w, h, depth, ctype, rows), codes[..., :n - 1] / (2 ** depth - 1)
        channels = n - 1
    path = tmp_path / f"{kind}.png"
    path.write_bytes(data)
    got = read_image(path, channels, transfer="linear")
    assert got.shape == want.shape, (got.shape, want.shape)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-6, err_msg=kind)


def test_half_float_exr_answers_read_at_full_precision(tmp_path):
    """A half-float EXR answer reads as its half values exactly (float32 holds every half), Y and RGB."""
    import OpenEXR

    from ldbench.harness.score import read_image

    rng = np.random.default_rng(3)
    v = (rng.random((6, 9), np.float32) * 8).astype(np.float16)
    for names in ("Y", "RGB"):
        chans = {c: np.ascontiguousarray(v if i == 0 else v[::-1] if i == 1 else v * 2) for i, c in enumerate(names)}
        path = tmp_path / f"{names}.exr"
        OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                     {c: OpenEXR.Channel(a) for c, a in chans.items()}).write(str(path))
        got = read_image(path, len(names), transfer=None)
        want = np.stack([chans[c].astype(np.float32) for c in names], -1)
        assert got.dtype == np.float32 and np.array_equal(got, want), names
