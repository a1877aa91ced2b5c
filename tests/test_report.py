"""The HTML report (ldbench/reports/report.py, ldbench/reports/figures/) on a small real run and on synthetic rows."""
from __future__ import annotations

import html.parser
import math
import re
import shutil
import subprocess
import urllib.parse
from pathlib import Path

import pytest

from ldbench.harness import records
from ldbench.reports.report import build_report, write_report

VOID = {"area", "base", "br", "col", "embed", "hr", "img", "input", "link", "meta", "source", "track", "wbr"}


class StrictParser(html.parser.HTMLParser):
    """Collects links and checks that every opened (non-void) tag is closed in order."""

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.stack, self.errors, self.srcs, self.hrefs, self.tags = [], [], [], [], []
        self.scripts = []

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)
        a = dict(attrs)
        if tag == "img":
            self.srcs.append(a.get("src"))
        if tag == "script":
            self.scripts.append(a)
        if tag == "a" and "href" in a:
            self.hrefs.append(a["href"])
        if tag not in VOID:
            self.stack.append((tag, self.getpos()))

    def handle_startendtag(self, tag, attrs):
        self.handle_starttag(tag, attrs)
        if tag not in VOID:
            self.stack.pop()

    def handle_endtag(self, tag):
        if tag in VOID:
            self.errors.append(f"closing void tag </{tag}> at {self.getpos()}")
            return
        if not self.stack or self.stack[-1][0] != tag:
            self.errors.append(f"</{tag}> at {self.getpos()} does not close {self.stack[-1] if self.stack else None}")
            return
        self.stack.pop()


def parse(path: Path) -> StrictParser:
    p = StrictParser()
    p.feed(path.read_text(encoding="utf-8"))
    p.close()
    return p


def local(run_dir: Path, link: str) -> Path:
    assert not re.match(r"^[a-z]+:", link) and not link.startswith("/"), f"non-relative link {link!r}"
    return run_dir / urllib.parse.unquote(link.split("#")[0])


# --------------------------------------------------------------------------------------------------
# a small real run: cornell, direct-raster, 32x32, two shadow-map sizes (a swept parameter)


@pytest.fixture(scope="module")
def real_run(tmp_path_factory):
    from ldbench.harness.executors import run_jobs
    from ldbench.harness.suite import suite_from_dict

    suite = suite_from_dict({
        "suite": {"name": "report-test", "size": "32x32", "spp": 4, "warmup": 0, "frames": 3},
        "run": [{"scene": "cornell", "effect": "direct", "methods": ["direct-raster"],
                 "params": {"direct-raster": {"shadow_size": [256, 1024]}}}],
    }, name="report-test")
    out = tmp_path_factory.mktemp("runs") / "run"
    run_jobs(suite, out, progress=False)  # writes the report at the end
    return out


def test_real_run_report_files(real_run):
    index = real_run / "index.html"
    assert index.is_file() and (real_run / "summary.md").is_file()
    p = parse(index)
    assert not p.errors, p.errors
    assert not p.stack, f"unclosed tags: {p.stack}"
    # scripts: only the inline viewer and its inert JSON data, nothing loaded from elsewhere
    assert all("src" not in a for a in p.scripts)
    assert [a.get("type") for a in p.scripts].count(None) == 1
    text = index.read_text(encoding="utf-8")
    assert "Report problems" not in text
    # every image and every local link resolves inside the run directory
    assert len(p.srcs) >= 6
    for s in p.srcs + p.hrefs:
        if s.startswith("#"):
            continue
        assert local(real_run, s).is_file(), f"missing {s}"
    # the header names the machine and commit, and warns about wall-clock times on llvmpipe
    for word in ("device", "GL renderer", "GL version", "driver", "CPU", "GPU", "commit", "run id"):
        assert f"<th>{word}</th>" in text
    df = records.read_results(real_run)
    if (df["device"] == "cpu-software").any():
        assert 'class="warn"' in text and "wall clock" in text


def test_real_run_figures_png_and_pdf(real_run):
    figs = real_run / "figures"
    pngs = sorted(figs.glob("*.png"))
    names = [p.name for p in pngs]
    for prefix in ("stages-", "time-vs-shadow_size", "memory-vs-shadow_size", "quality-", "grid-"):
        assert any(n.startswith(prefix) for n in names), (prefix, names)
    import matplotlib.image as mpimg

    for png in pngs:
        pdf = png.with_suffix(".pdf")
        assert pdf.is_file() and pdf.read_bytes()[:5] == b"%PDF-", pdf
        img = mpimg.imread(str(png))
        assert img.std() > 0.01, f"{png.name} looks blank"
    # the HTML grid: error maps re-coloured on one scale + a colour bar
    grid_dirs = list((figs / "grids").iterdir())
    assert len(grid_dirs) == 1
    assert (grid_dirs[0] / "colorbar.png").is_file()
    assert len(list(grid_dirs[0].glob("*-error.png"))) == 2


def test_report_cli_rebuilds(real_run, tmp_path):
    from ldbench.harness.cli import main

    d = tmp_path / "copy"
    shutil.copytree(real_run, d)
    shutil.rmtree(d / "figures")
    (d / "index.html").unlink()
    assert main(["report", str(d)]) == 0
    assert (d / "index.html").is_file() and any((d / "figures").glob("stages-*.pdf"))
    assert main(["report", str(tmp_path / "nope")]) == 2


def test_hostile_names_are_escaped(real_run, tmp_path):
    """A scene called <script>…</script> and odd method/params/status text never reach the HTML raw."""
    d = tmp_path / "hostile"
    shutil.copytree(real_run, d)
    df = records.read_results(d)
    rows = [r.to_dict() for _, r in df.iterrows()]
    rows[0]["scene"] = "<script>alert('x')</script>"
    rows[0]["method"] = 'direct-raster"><img src=x onerror=alert(1)>'
    rows[1]["status"] = "error: <b>bad</b> & worse"
    rows[1]["gl_renderer"] = "<i>renderer</i>"
    records.write_results(rows, d)
    write_report(d)
    text = (d / "index.html").read_text(encoding="utf-8")
    assert "<script>alert" not in text.lower()
    assert "&lt;script&gt;alert(&#x27;x&#x27;)&lt;/script&gt;" in text
    assert "<img src=x" not in text and "<b>bad</b>" not in text and "<i>renderer</i>" not in text
    p = parse(d / "index.html")
    assert not p.errors and not p.stack
    assert all("src" not in a for a in p.scripts) and [a.get("type") for a in p.scripts].count(None) == 1
    assert "i" not in p.tags  # the report itself uses no <i>
    for s in p.srcs:
        assert local(d, s).is_file(), s


# --------------------------------------------------------------------------------------------------
# synthetic rows: d_max sweeps (with inf), two methods, an error row, no images


def synthetic_rows():
    rows = []
    for method, base in (("ldm-ao", 40.0), ("hbao", 5.0)):
        for d in (0.5, 2.0, 10.0, math.inf):
            grow = 1.0 if method == "ldm-ao" else (1 + (d if math.isfinite(d) else 40.0))
            t = base * grow
            raw = {"build": [t * 0.6] * 3, "trace": [t * 0.4] * 3, "total": [t * 0.95, t, t * 1.1]}
            rows.append(records.make_row(
                run_id="synthetic", suite="synthetic", scene="atrium", method=method, paper="aalund2015",
                effect="ao", effect_params={"effect": "ao", "d_max": "inf" if math.isinf(d) else d,
                                            "falloff": "quadratic"},
                params={"directions": 512, "resolution": 200} if method == "ldm-ao" else {"directions": 8},
                width=64, height=64, device="nvidia", gl_renderer="NVIDIA H100/PCIe/SSE2",
                gl_version="4.6.0 NVIDIA 550.54", driver="NVIDIA 550.54", cpu="Xeon", gpu_name="NVIDIA H100",
                commit="abc123", dirty=False, status="ok",
                memory={"nodes": (800 if method == "ldm-ao" else 4) * 2**20},
                psnr=30.0 + (5 if method == "ldm-ao" else -d if math.isfinite(d) else -20),
                ssim=0.9, flip=0.05, relmse=0.01, ref_spp=64,
                **records.timing_fields(raw)))
    rows.append(records.make_row(run_id="synthetic", suite="synthetic", scene="atrium", method="ldm-ao",
                                 effect="ao", effect_params={"effect": "ao", "d_max": 1.0, "falloff": "step"},
                                 params={"directions": 4096}, width=64, height=64, device="nvidia",
                                 status="error: node pool overflow <4096>"))
    return rows


def test_synthetic_sweep_figures(tmp_path):
    records.write_results(synthetic_rows(), tmp_path)
    out = build_report(tmp_path)
    assert not out["problems"], out["problems"]
    kinds = {f.kind for f in out["figures"]}
    assert {"stages", "time-vs-param", "memory-vs-param", "quality"} <= kinds
    assert (tmp_path / "figures" / "time-vs-d_max.png").is_file()
    assert (tmp_path / "figures" / "time-vs-d_max.pdf").is_file()
    text = (tmp_path / "index.html").read_text(encoding="utf-8")
    assert 'class="warn"' not in text  # an NVIDIA run: no software-rasterizer warning
    assert "node pool overflow &lt;4096&gt;" in text
    p = parse(tmp_path / "index.html")
    assert not p.errors and not p.stack
    for s in p.srcs:
        assert local(tmp_path, s).is_file(), s


def test_swept_parameters_and_pareto():
    from ldbench.reports.figures.quality import pareto_front
    from ldbench.reports.figures.table import prepare, swept_parameters
    import pandas as pd

    df = prepare(pd.DataFrame(synthetic_rows()))
    swept = swept_parameters(df)
    assert "d_max" in swept and "directions" not in swept  # directions differ only across methods
    assert pareto_front([1, 2, 3, 4], [10, 9, 12, 12], True) == [0, 2]
    assert pareto_front([1, 2, 3], [0.3, 0.1, 0.2], False) == [0, 1]


def test_report_survives_a_broken_figure(tmp_path, monkeypatch):
    from ldbench.reports import figures as F

    records.write_results(synthetic_rows(), tmp_path)

    def boom(*a, **k):
        raise RuntimeError("plot <failed>")

    monkeypatch.setattr(F, "figure_stages", boom)
    out = build_report(tmp_path)
    assert any("plot <failed>" in p for p in out["problems"])
    text = (tmp_path / "index.html").read_text(encoding="utf-8")
    assert "plot &lt;failed&gt;" in text


# --------------------------------------------------------------------------------------------------
# what a person sees: a headless Chromium screenshot


def _chromium():
    return shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")


@pytest.mark.skipif(_chromium() is None, reason="chromium not installed: the report screenshot went untested")
def test_screenshot_not_blank(real_run, tmp_path):
    shot = tmp_path / "report.png"
    cmd = [_chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
           "--disable-background-networking", "--disable-component-update", "--disable-sync",
           f"--user-data-dir={tmp_path / 'profile'}", f"--screenshot={shot}", "--window-size=1400,2400",
           (real_run / "index.html").resolve().as_uri()]
    subprocess.run(cmd, capture_output=True, timeout=120)
    assert shot.is_file() and shot.stat().st_size > 10_000
    import matplotlib.image as mpimg

    img = mpimg.imread(str(shot))[..., :3]
    assert img.shape[0] >= 2000 and img.shape[1] >= 1400
    assert float(img.std()) > 0.05, "screenshot is (nearly) blank"
    # colourful content (plots, error maps), not only black text on white
    sat = img.max(-1) - img.min(-1)
    assert float((sat > 0.3).mean()) > 0.01


def test_overwritten_images_are_flagged(real_run, tmp_path):
    """Two configurations pointing at one image file (a runner name collision) are flagged on the page."""
    d = tmp_path / "clash"
    shutil.copytree(real_run, d)
    df = records.read_results(d)
    rows = [r.to_dict() for _, r in df.iterrows()]
    rows[1]["images"] = rows[0]["images"]
    records.write_results(rows, d)
    out = build_report(d)
    assert any("shared with other rows" in p for g in out["grids"] for p in g.problems)
    assert "shared with other rows" in (d / "index.html").read_text(encoding="utf-8")


def test_ray_rows_get_their_table_and_accuracy_figure(tmp_path):
    """Non-image effects: a table of the effect's own metrics and the accuracy-vs-rays/s figure with the
    oracle; no empty image table."""
    rows = []
    for i, (method, agree, rps) in enumerate((("ldm", 0.976, 3e8), ("ldm", 0.95, 9e8))):
        rows.append(records.make_row(
            run_id="r", suite="s", scene="cornell", method=method, effect="rays",
            effect_params={"effect": "rays", "ray_kind": "diffuse", "rays_per_pixel": 4},
            params={"directions": 512 >> i}, width=64, height=64, device="nvidia", gl_renderer="NVIDIA H200",
            total_ms=10.0, raw_ms={"total": [10.0, 10.1, 9.9]}, stage_ms={"build": 9.0, "trace": 1.0},
            memory={"nodes": 2 ** 20}, hit_agreement=agree, dist_err_p95=0.05, self_hit_rate=0.003,
            rays=61504, rays_per_s=rps, oracle_rays_per_s=1.7e9, oracle_timing="kernel", images={}))
    records.write_results(rows, tmp_path)
    out = build_report(tmp_path)
    page = (tmp_path / "index.html").read_text()
    assert "Effect <code>rays</code>" in page and "0.976" in page and "1700 M" in page
    assert [f.kind for f in out["figures"]].count("rays") == 1
    summary = (tmp_path / "summary.md").read_text()
    assert "## Effect `rays`" in summary and "PSNR dB" not in summary


def test_leaderboard_says_who_wins(tmp_path):
    """One board per scene × effect × size, ranked by PSNR (best first, ties by time), ★ on the Pareto
    front of PSNR and time, failed rows below the ranking with their status; at the top of both pages."""
    import pandas as pd

    from ldbench.reports.figures.table import prepare
    from ldbench.reports.report import boards

    rows = synthetic_rows()
    rows.append(records.make_row(run_id="synthetic", suite="synthetic", scene="atrium", method="gtao", effect="ao",
                                 effect_params={"effect": "ao", "d_max": 1.0, "falloff": "step"}, width=32,
                                 height=32, device="nvidia", status="ok", psnr=20.0, total_ms=1.0))
    df = prepare(pd.DataFrame(rows))
    bs = boards(df)
    assert [(b.effect, b.size) for b in bs] == [(e, "64x64") for e in dict.fromkeys(df["effect_text"][:9])] + \
        [("ao (step, d_max = 1)", "32x32")]
    inf = next(b for b in bs if "∞" in b.effect)
    ranked = inf.ranked
    assert [e.method for e in ranked] == ["ldm-ao", "hbao"] and ranked[0].value == 35.0 and ranked[1].value == 10.0
    assert ranked[0].total_ms == 40.0 and ranked[1].total_ms == 205.0
    assert ranked[0].pareto and not ranked[1].pareto  # ldm is faster and better here
    small = next(b for b in bs if "d_max = 0.5" in b.effect)  # hbao faster, ldm better: both on the front
    assert [e.method for e in small.ranked] == ["ldm-ao", "hbao"] and all(e.pareto for e in small.ranked)
    failed = next(b for b in bs if b.effect.startswith("ao (step") and b.size == "64x64")
    assert failed.ranked == [] and "overflow" in failed.unranked[0].status
    records.write_results(rows, tmp_path)
    build_report(tmp_path)
    md = (tmp_path / "summary.md").read_text()
    assert md.index("## Leaderboard") < md.index("## All rows") and "| 1 | ldm-ao |" in md and "★" in md
    html = (tmp_path / "index.html").read_text()
    assert html.index('id="leaderboard"') < html.index('id="results"')


def test_a_method_keeps_its_colour_from_report_to_report():
    """A method's colour depends on its name only (not on which other methods a run holds, nor their order):
    the built-in methods have distinct fixed colours, a plugin's is picked by its name, the oracle is black."""
    from ldbench.methods.base import registry
    from ldbench.reports.figures.colours import method_colours

    builtin = [m for m in registry() if registry()[m].__module__.startswith("ldbench.")]
    one = method_colours(builtin)
    assert len(set(one.values())) == len(builtin)
    assert method_colours(["gtao", "hbao"])["hbao"] == method_colours(["hbao"])["hbao"] == one["hbao"]
    assert method_colours(["my-ao", "hbao"])["my-ao"] == method_colours(["ldm", "my-ao"])["my-ao"]
    assert method_colours(["oracle (Mitsuba)"])["oracle (Mitsuba)"] == (0.0, 0.0, 0.0, 1.0)


def test_a_sweep_of_a_choice_parameter_is_named_and_labelled(tmp_path):
    """hbao's sampling left at its default in one row and set to pixel_step in another: a swept parameter
    (the defaults filled in), labelled with its value in both rows, never 'None'; and a parameter of one
    method only is no label part of another's rows."""
    import pandas as pd

    from ldbench.reports.figures.table import prepare
    from ldbench.reports.labels import differing_keys, label_parts
    from ldbench.reports.report import swept_params

    base = dict(run_id="s", suite="s", scene="cornell", effect="ao", effect_params={"effect": "ao", "d_max": 0.5,
                "falloff": "step"}, width=16, height=16, device="nvidia", status="ok", psnr=20.0, total_ms=1.0)
    rows = [records.make_row(method="hbao", params={}, **base),
            records.make_row(method="hbao", params={"sampling": "pixel_step"}, **base),
            records.make_row(method="gtao", params={}, **base)]
    df = prepare(pd.DataFrame(rows))
    assert swept_params(df) == {"hbao": {"sampling"}, "gtao": set()}
    diff = differing_keys([r for _, r in df.iterrows()])
    assert diff == ["sampling"]
    assert [label_parts(r, diff) for _, r in df.iterrows()] == \
        [["hbao", "sampling=fixed"], ["hbao", "sampling=pixel_step"], ["gtao"]]
    records.write_results(rows, tmp_path)
    build_report(tmp_path)
    html = (tmp_path / "index.html").read_text()
    assert "Swept without a numeric axis: sampling" in html and "No parameter is swept" not in html
    assert "sampling=None" not in html


def test_summary_device_line_of_a_scored_answer_and_of_missing_fields():
    """summary.md's device line never prints None or nan: a scored answer (device external) says it was
    rendered outside ldbench; a machine field the table lacks reads "–"."""
    from ldbench.reports.report import _device_line

    ext = _device_line({"device": "external", "gl_renderer": None, "gl_version": None, "driver": None,
                        "cpu": float("nan"), "gpu_name": None})
    assert "outside ldbench" in ext and "None" not in ext and "nan" not in ext, ext
    gpu = _device_line({"device": "nvidia", "gl_renderer": "NVIDIA H200", "gl_version": "4.3", "driver": "580",
                        "cpu": "x86", "gpu_name": float("nan")})
    assert "**nvidia** — NVIDIA H200 (4.3); driver 580; CPU x86; GPU –" in gpu and "nan" not in gpu, gpu
