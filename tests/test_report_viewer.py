"""The report's image viewer, signed-error and FLIP maps, non-default parameter tables, figure layout.

A small real llvmpipe run (cornell, ao, hbao + ldm at 32x32) builds the report. The viewer is driven in
headless Chromium through the page's URL hash (``#ldv=<grid>&keys=...``: the keys go through the page's
own keydown handler) and read back with ``--dump-dom`` (the viewer mirrors its state in ``data-*``
attributes) and ``--screenshot``. Without Chromium those tests skip with a reason naming it, and the
terminal summary says so in one loud line (tests/conftest.py).
"""
from __future__ import annotations

import base64
import json
import re
import shutil
import subprocess
import urllib.parse
from pathlib import Path

import numpy as np
import pytest

from ldbench.core import metrics
from ldbench.harness import records
from ldbench.reports.report import build_report, shown_params, terminal_table

CHROMIUM_SKIP = "chromium not installed: the report's image viewer went untested in a browser"


def _chromium():
    return shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")


needs_chromium = pytest.mark.skipif(_chromium() is None, reason=CHROMIUM_SKIP)


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    from ldbench.harness.executors import run_jobs
    from ldbench.harness.suite import suite_from_dict

    suite = suite_from_dict({
        "suite": {"name": "viewer-test", "size": "32x32", "spp": 4, "warmup": 0, "frames": 2},
        "run": [{"scene": "cornell", "effect": "ao", "d_max": 0.5, "methods": ["hbao", "ldm"],
                 "params": {"ldm": {"directions": 16, "resolution": 32}}}],
    }, name="viewer-test")
    out = tmp_path_factory.mktemp("viewer") / "run"
    run_jobs(suite, out, progress=False)
    return out


@pytest.fixture(scope="module")
def built(run):
    out = build_report(run)
    assert not out["problems"], out["problems"]
    (g,) = out["grids"]
    return out, g


def _read_exr(path):
    from ldbench.core.exr import read_answer_channels

    return read_answer_channels(Path(path))


def _values(path: Path) -> np.ndarray:
    m = re.fullmatch(r'ldbenchValues\("([^"]+)",(\d+),(\d+),(\d+),"([A-Za-z0-9+/=]*)"\);\n',
                     path.read_text(encoding="ascii"))
    assert m, path
    w, h, c = int(m[2]), int(m[3]), int(m[4])
    return np.frombuffer(base64.b64decode(m[5]), "<f4").reshape(h, w, c)


# --------------------------------------------------------------------------------------------------
# maps and values written with the report


def test_signed_and_flip_maps_with_ranges(run, built):
    _, g = built
    df = records.read_results(run).set_index("method")
    maps = json.loads((run / g.maps_json).read_text())
    lo, hi = maps["signed"]["range"]
    assert lo == -hi and hi == pytest.approx(g.signed_vmax) and hi > 0
    assert maps["flip"]["range"] == [0.0, 1.0]
    ref = _read_exr(run / g.reference_exr)
    import matplotlib.image as mpimg

    for c in g.cells:
        test = _read_exr(run / c.exr)
        signed = mpimg.imread(str(run / c.signed))[..., :3]
        flip = mpimg.imread(str(run / c.flip))[..., :3]
        assert signed.shape[:2] == flip.shape[:2] == ref.shape[:2]
        d = (test - ref).mean(-1)
        # diverging map: red where the method is brighter, blue where darker, white at 0
        brighter, darker = d > 0.3 * hi, d < -0.3 * hi
        if brighter.any():
            assert (signed[brighter, 0] > signed[brighter, 2]).mean() > 0.95
        if darker.any():
            assert (signed[darker, 2] > signed[darker, 0]).mean() > 0.95
        assert np.allclose(signed[d == 0], 247 / 255, atol=0.02)  # RdBu_r's centre is near-white
        # the values behind the FLIP map are FLIP's own (over every pixel: the run stores no hit mask),
        # and the PNG shows them with magma on 0 … 1
        fv = _values(run / c.flip_values)[..., 0]
        assert np.array_equal(fv, metrics.flip(test, ref)[1])
        assert fv.max() > 0.1 and 0.3 * fv.mean() < df.loc[c.label.split(" ")[0], "flip"] < 3 * fv.mean()
        assert np.allclose(flip, metrics.colorize(fv, vmax=1.0)[..., :3] / 255, atol=1 / 255 + 1e-6)
        # the image's float values are the EXR's, exactly
        assert np.array_equal(_values(run / c.values), test)
    assert np.array_equal(_values(run / g.reference_values), ref)


def test_values_over_the_size_limit_are_skipped(tmp_path, monkeypatch):
    from ldbench.core import imageio

    monkeypatch.setattr(imageio, "VALUES_MAX_PIXELS", 15)
    assert not imageio.save_values_js(tmp_path / "a.js", "a.js", np.zeros((4, 4, 1)))
    assert imageio.save_values_js(tmp_path / "b.js", "b.js", np.zeros((3, 5)))
    assert _values(tmp_path / "b.js").shape == (3, 5, 1)


def test_value_files_stop_at_the_reports_budget(run, tmp_path):
    from ldbench.reports.figures.grids import grid_groups, make_grid
    from ldbench.reports.figures.table import prepare

    df = prepare(records.read_results(run))
    key, rows = next(iter(grid_groups(df).items()))
    d = tmp_path / "r"
    shutil.copytree(run, d)
    shutil.rmtree(d / "figures")
    one = 32 * 32 * 4 * 4 // 3  # one 1-channel 32x32 image
    budget = {"bytes": 2 * one + 10}  # the reference and the first method, not the FLIP map or the second
    g = make_grid(d, key, rows, values_budget=budget)
    assert g.reference_values and g.cells[0].values and not g.cells[0].flip_values
    assert not g.cells[1].values and budget["bytes"] == 10
    assert g.cells[1].signed and g.cells[1].flip  # the maps themselves are always written


def test_grid_links_full_size_files(run, built):
    _, g = built
    text = (run / "index.html").read_text(encoding="utf-8")
    for rel in (g.reference, g.reference_exr, *(c.exr for c in g.cells), *(c.image for c in g.cells)):
        assert f'href="{urllib.parse.quote(rel)}"' in text, rel
    assert text.count('data-ldv="') == 1 + 4 * len(g.cells)  # reference + image, |error|, signed, FLIP


# --------------------------------------------------------------------------------------------------
# readable tables


def test_only_non_default_params_grouped(run, built):
    assert shown_params("hbao", {}) == []
    from ldbench.methods.base import get_method

    full = get_method("ldm").Params().to_dict()
    assert shown_params("ldm", {**full, "directions": 16}) == [("", [("directions", 16)])]
    # values that went through the records (int as float, tuples as lists) still equal their defaults
    assert shown_params("ldm", {k: (float(v) if isinstance(v, int) and not isinstance(v, bool) else v)
                                for k, v in full.items()}) == []
    # dotted names group by their prefix, ungrouped first; unknown methods show everything
    got = shown_params("no-such-method", {"structure.source": "peel", "bias": 0.5, "structure.depth": 4})
    assert got == [("", [("bias", 0.5)]), ("structure", [("source", "peel"), ("depth", 4)])]
    summary = (run / "summary.md").read_text()
    row = next(line for line in summary.splitlines() if line.startswith("| cornell | ldm "))
    assert "directions=16" in row and "resolution=32" in row and "layout=" not in row
    assert "| cornell | hbao | ao (step, d_max = 0.5) | 32×32 | defaults |" in summary
    page = (run / "index.html").read_text()
    assert "<td>directions=16, resolution=32</td>" in page and "layout=" not in page
    assert len(records.read_results(run).set_index("method").loc["ldm", "params"]) > 20  # full set kept


def test_swept_parameters_show_in_every_row():
    """A sweep that includes the default value shows the parameter in that row too."""
    import pandas as pd

    from ldbench.reports.report import swept_params, _results_table, _Html
    from ldbench.reports.figures.table import prepare

    rows = [records.make_row(run_id="r", suite="s", scene="cornell", method="ldm", effect="ao",
                             effect_params={"effect": "ao", "d_max": 1.0, "falloff": "step"},
                             params={"directions": d, "bias": 0.25}, width=8, height=8, device="nvidia",
                             status="ok", total_ms=1.0)
            for d in (128, 512)]  # 128 and bias 0.25 are ldm's defaults
    df = prepare(pd.DataFrame(rows))
    assert swept_params(df) == {"ldm": {"directions"}}
    h = _Html()
    _results_table(h, df)
    page = str(h)
    assert "<td>directions=128</td>" in page and "<td>directions=512</td>" in page and "bias" not in page


def test_terminal_table_shows_each_effects_metrics(run):
    df = records.read_results(run)
    text = terminal_table(df)
    head = text.splitlines()[0]
    assert "psnr" in head and "flip" in head and "layout=" not in text and "directions=16" in text
    rays = records.make_row(run_id="r", suite="s", scene="cornell", method="ldm", effect="rays",
                            effect_params={"effect": "rays", "ray_kind": "diffuse", "rays_per_pixel": 4},
                            params={"directions": 512}, width=8, height=8, device="nvidia", total_ms=1.0,
                            hit_agreement=0.9765, rays_per_s=3e8, rays=256, images={})
    import pandas as pd

    both = terminal_table(pd.concat([df, pd.DataFrame([rays])], ignore_index=True))
    blocks = both.split("\n\n")
    assert len(blocks) == 2
    assert "hit_agreement" in blocks[1] and "0.9765" in blocks[1] and "psnr" not in blocks[1]
    assert "NaN" not in both and "nan" not in both


# --------------------------------------------------------------------------------------------------
# figure layout


def test_stage_bars_leave_headroom(tmp_path, monkeypatch):
    """The tallest bar has a zero-height stage on top (a stage only the other method has): matplotlib's
    autoscale alone would end the axis exactly at its top."""
    from ldbench.reports.figures import stages
    from ldbench.reports.figures.table import prepare
    import pandas as pd

    rows = [records.make_row(run_id="r", suite="s", scene="cornell", method=m, effect="ao",
                             effect_params={"effect": "ao", "d_max": 1.0, "falloff": "step"}, params={},
                             width=8, height=8, device="nvidia", status="ok", total_ms=sum(st.values()),
                             stage_ms=st)
            for m, st in (("hbao", {"gbuffer": 10.0, "hbao": 5.0}), ("ldm", {"build": 3.0}))]
    seen = []
    monkeypatch.setattr(stages, "save", lambda fig, run_dir, name: (seen.append(fig), {"png": "", "pdf": ""})[1])
    stages.figure_stages(prepare(pd.DataFrame(rows)), tmp_path, "cornell")
    (fig,) = seen
    ax = fig.axes[0]
    top = max(p.get_y() + p.get_height() for p in ax.patches)
    assert ax.get_ylim()[1] >= 1.05 * top


def test_single_method_grid_keeps_colour_bar_labels(run, tmp_path):
    """The colour bar of a one-method grid lies right of the last axes; nothing may touch the border."""
    from ldbench.reports.figures.grids import grid_groups, make_grid
    from ldbench.reports.figures.table import prepare
    import matplotlib.image as mpimg

    df = prepare(records.read_results(run))
    key, rows = next(iter(grid_groups(df).items()))
    d = tmp_path / "r"
    shutil.copytree(run, d)
    g = make_grid(d, key, rows[:1])
    img = mpimg.imread(str(d / g.png))[..., :3]
    border = np.concatenate([img[:3].reshape(-1, 3), img[-3:].reshape(-1, 3),
                             img[:, :3].reshape(-1, 3), img[:, -3:].reshape(-1, 3)])
    assert border.min() > 0.95, "something is cut off at the figure's edge"


# --------------------------------------------------------------------------------------------------
# the viewer in headless Chromium


def _browser(tmp_path, page: Path, hash_: str, *, shot: Path | None = None, size="1200,800") -> str:
    prof = tmp_path / f"profile-{len(list(tmp_path.glob('profile-*')))}"
    cmd = [_chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
           "--disable-component-update", "--disable-sync", "--no-first-run", f"--user-data-dir={prof}",
           "--virtual-time-budget=4000", f"--window-size={size}"]
    cmd += [f"--screenshot={shot}"] if shot else ["--dump-dom"]
    r = subprocess.run(cmd + [page.resolve().as_uri() + "#" + hash_], capture_output=True, text=True, timeout=120)
    return r.stdout


def _state(dom: str) -> dict:
    m = re.search(r'<div class="ldv" id="ldv"([^>]*)>', dom)
    assert m, "viewer element missing"
    st = dict(re.findall(r'data-([a-z]+)="([^"]*)"', m[1]))
    px = re.search(r'<div class="ldv-px" id="ldv-px">([^<]*)<', dom)
    st["readout"] = px[1] if px else ""
    return st


@needs_chromium
def test_viewer_flips_zooms_and_reads_values(run, built, tmp_path):
    _, g = built
    page = run / "index.html"
    a = g.anchor
    ref, m1, m2 = g.reference, g.cells[0].image, g.cells[1].image
    s = _state(_browser(tmp_path, page, f"ldv={a}"))
    assert s["shown"] == ref and s["idx"] == "0" and s["mode"] == "image"
    s = _state(_browser(tmp_path, page, f"ldv={a}&keys=ArrowRight"))
    assert s["shown"] == m1 and s["idx"] == "1"
    s = _state(_browser(tmp_path, page, f"ldv={a}&keys=ArrowRight,ArrowRight,Space"))
    assert s["shown"] == ref  # space: back to the reference ...
    s = _state(_browser(tmp_path, page, f"ldv={a}&keys=3,Space,Space,f&zoom=4&at=7,9"))
    assert s["shown"] == g.cells[1].flip and s["mode"] == "flip"  # ... and to the last method shown
    assert float(s["zoom"]) == 4.0
    # exact float values under the cursor
    x, y = 7, 9
    want_ref = _read_exr(run / g.reference_exr)[y, x, 0]
    want_m = _read_exr(run / g.cells[1].exr)[y, x, 0]
    want_f = _values(run / g.cells[1].flip_values)[y, x, 0]
    nums = dict(re.findall(r"(reference|ldm|FLIP) (-?[0-9.e+-]+)", s["readout"]))
    assert float(nums["reference"]) == pytest.approx(want_ref, rel=1e-4, abs=1e-6)
    assert float(nums["ldm"]) == pytest.approx(want_m, rel=1e-4, abs=1e-6)
    assert float(nums["FLIP"]) == pytest.approx(want_f, rel=1e-4, abs=1e-6)
    s = _state(_browser(tmp_path, page, f"ldv={a}&idx=2&keys=b,s"))
    assert s["sbs"] == "1" and s["left"] == ref and s["shown"] == g.cells[1].signed and m2 != ref


@needs_chromium
def test_viewer_screenshots_show_the_flip_and_zoom(run, built, tmp_path):
    import matplotlib.image as mpimg

    _, g = built
    page = run / "index.html"
    shots = {}
    for name, h in (("ref", f"ldv={g.anchor}&zoom=8"), ("m1", f"ldv={g.anchor}&keys=ArrowRight&zoom=8"),
                    ("ref16", f"ldv={g.anchor}&zoom=16")):
        p = tmp_path / f"{name}.png"
        _browser(tmp_path, page, h, shot=p)
        assert p.is_file(), name
        shots[name] = mpimg.imread(str(p))[..., :3]
    img = shots["ref"]
    assert img.std() > 0.05, "screenshot is (nearly) blank"
    # the stage (between the bars) shows the 32x32 image at 8x (256 px), centred: compare that region
    h, w = img.shape[:2]
    box = (slice(h // 2 - 100, h // 2 + 100), slice(w // 2 - 100, w // 2 + 100))
    assert np.abs(shots["ref"][box] - shots["m1"][box]).mean() > 0.01, "flipping did not change the pixels"
    assert np.abs(shots["ref"][box] - shots["ref16"][box]).mean() > 0.01, "zooming did not change the pixels"
    # nearest-neighbour: at 16x, every 16x16 block of the image is one colour (few distinct values per row)
    row = shots["ref16"][h // 2, w // 2 - 128:w // 2 + 128]
    changes = int((np.abs(np.diff(row, axis=0)).max(-1) > 1.5 / 255).sum())
    assert changes <= 256 // 16 + 2, changes


@needs_chromium
def test_page_screenshot_not_blank(run, tmp_path):
    p = tmp_path / "page.png"
    _browser(tmp_path, run / "index.html", "", shot=p, size="1300,2600")
    import matplotlib.image as mpimg

    img = mpimg.imread(str(p))[..., :3]
    assert img.std() > 0.05
    assert float(((img.max(-1) - img.min(-1)) > 0.3).mean()) > 0.01  # plots and colour maps


@needs_chromium
def test_thumbnail_click_opens_the_viewer(run, built, tmp_path):
    """A real click event on the FLIP thumbnail of the second method opens the viewer there."""
    _, g = built
    page = run / "click.html"
    text = (run / "index.html").read_text(encoding="utf-8")
    click = ('<script>window.addEventListener("load", function () { document.querySelector('
             '\'a[data-idx="2"][data-mode="flip"]\').click(); });</script></body>')
    page.write_text(text.replace("</body>", click), encoding="utf-8")
    try:
        s = _state(_browser(tmp_path, page, ""))
    finally:
        page.unlink()
    assert s["shown"] == g.cells[1].flip and s["idx"] == "2" and s["mode"] == "flip"
    dom_closed = _browser(tmp_path, run / "index.html", "")
    assert re.search(r'<div class="ldv" id="ldv" hidden', dom_closed) or 'hidden=""' in dom_closed


def test_run_prints_each_effects_metrics(tmp_path, capsys):
    from ldbench.harness.cli import main

    main(["run", "--scene", "cornell", "--effect", "rays", "--ray-kind", "diffuse", "--rays-per-pixel", "1",
          "--method", "ldm", "--set", "ldm.directions=16", "--set", "ldm.resolution=32", "--size", "16x16",
          "--frames", "1", "--warmup", "0", "--no-progress", "--no-report", "--out", str(tmp_path / "r")])
    out = capsys.readouterr().out
    head = next(line for line in out.splitlines() if line.lstrip().startswith("scene"))
    assert "hit_agreement" in head and "rays_per_s" in head and "psnr" not in head
    assert "NaN" not in out and "directions=16, resolution=32" in out and "layout=" not in out


@needs_chromium
def test_viewer_mouse_wheel_drag_and_readout(run, built, tmp_path):
    """Synthetic mouse events through the page's own listeners: the wheel zooms by 1.25, a drag pans by
    the mouse's travel, the cursor over the centre of the right-hand image (side by side) reads pixel
    (16, 16) of the 32x32 image."""
    page = run / "mouse.html"
    text = (run / "index.html").read_text(encoding="utf-8")
    script = """<script>window.addEventListener("load", function () {
      document.querySelector('a[data-idx="1"][data-mode="image"]').click();
      var v = document.getElementById("ldv"), b = document.body;
      var img = function () { return document.querySelector(".ldv-pane:not([hidden]) img"); };
      var at = function (type, x, y, extra) {
        var o = Object.assign({clientX: x, clientY: y, bubbles: true}, extra || {});
        img().dispatchEvent(type === "wheel" ? new WheelEvent(type, o) : new MouseEvent(type, o));
      };
      var r = img().getBoundingClientRect(), cx = r.left + r.width / 2, cy = r.top + r.height / 2;
      b.setAttribute("data-z0", v.getAttribute("data-zoom"));
      at("wheel", cx, cy, {deltaY: -100});
      b.setAttribute("data-z1", v.getAttribute("data-zoom"));
      r = img().getBoundingClientRect();
      at("mousedown", cx, cy); at("mousemove", cx + 40, cy + 10); window.dispatchEvent(new MouseEvent("mouseup"));
      var r2 = img().getBoundingClientRect();
      b.setAttribute("data-pan", (r2.left - r.left) + "," + (r2.top - r.top));
      document.dispatchEvent(new KeyboardEvent("keydown", {key: "b", bubbles: true}));
      var imgs = document.querySelectorAll(".ldv-pane:not([hidden]) img"), right = imgs[imgs.length - 1];
      r = right.getBoundingClientRect();
      right.dispatchEvent(new MouseEvent("mousemove", {clientX: r.left + r.width / 2 + 0.5,
                                                       clientY: r.top + r.height / 2 + 0.5, bubbles: true}));
    });</script></body>"""
    page.write_text(text.replace("</body>", script), encoding="utf-8")
    try:
        dom = _browser(tmp_path, page, "")
    finally:
        page.unlink()
    body = dict(re.findall(r'data-(z0|z1|pan)="([^"]*)"', re.search(r"<body[^>]*>", dom)[0]))
    assert float(body["z1"]) == pytest.approx(1.25 * float(body["z0"]))
    dx, dy = map(float, body["pan"].split(","))
    assert (dx, dy) == (pytest.approx(40, abs=0.01), pytest.approx(10, abs=0.01))
    assert _state(dom)["readout"].startswith("x 16, y 16 · reference ")
