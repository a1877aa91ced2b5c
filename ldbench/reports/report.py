"""Reports of a run directory: ``index.html``, ``summary.md``, figures and image grids.

``write_report(run_dir)`` reads ``results.parquet`` (or ``.csv``) and writes:

* ``index.html`` — one self-contained page (inline CSS and one inline script, the image viewer of
  ``report_viewer.js``; no network: every link is a relative path inside the run directory, every
  string from the records is escaped with :func:`html.escape`, the viewer's JSON data escapes ``<``).
  Sections: the machine/commit header (device, GL renderer and version, driver, CPU, GPU name, commit + dirty flag, run id, time; a red warning when ``device = cpu-software``,
  because then every time is wall clock on a software rasterizer), the leaderboards
  (:mod:`ldbench.reports.leaderboard`: who wins per scene × effect × size), the results table, the figures,
  one image grid per scene × effect × size, and the paper-reproduction tables when the run was made by
  ``ldbench reproduce`` (``reproduce.json``).
* ``figures/`` — see :mod:`ldbench.reports.figures`: stage-time breakdowns (``stages-*``), time and memory
  against each swept parameter (``time-vs-*``, ``memory-vs-*``), quality vs time with the Pareto front
  (``quality-*``), and the image grids (``grid-*`` plus ``grids/<tag>/`` assets), each as PNG and PDF.
* ``summary.md`` — the leaderboards and the results table in Markdown with links to the figures.

Tables list only the parameters that differ from the adapter's defaults (:func:`shown_params`); the
results files keep the full set. docs/reference/reports.md describes the page and the viewer.

A figure that fails is listed on the page (and on stderr) instead of aborting the report, so a long GPU
run is never lost to a plotting problem.
"""
from __future__ import annotations

import html
import json
import logging
import math
import sys
import urllib.parse
from pathlib import Path

from .figures import write_figures
from .figures.grids import grid_groups, make_grid
from .figures.table import as_dict, prepare
from .figures.viewer_values import VALUES_BUDGET_BYTES
from . import labels
from .leaderboard import leaderboards
from ldbench.core.device import MACHINE_FIELDS
from ldbench.core.effects import get_spec, registry
from ldbench.core.files import atomic_write_text
from ldbench.harness.records import read_results

# Heavy: pandas is imported by terminal_table() alone.

# --------------------------------------------------------------------------------------------------
# formatting


def _fmt(v, nd=2):
    v2 = labels.as_number(v) if not isinstance(v, str) else v
    if v2 is None:
        return "–"
    if isinstance(v2, str):
        return v2
    if math.isinf(v2):
        return "∞"
    return f"{v2:.{nd}f}"


def shown_params(method, p, keep=()) -> list:
    """The parameters of one row that differ from the adapter's defaults (plus those named in ``keep``,
    e.g. swept ones), grouped as the adapter groups them: ``[(group, [(name, value), ...]), ...]`` with
    the ungrouped ones first under group ``""``. A dotted name ("structure.source") belongs to the group
    before its first dot; old flat names are read through ``Params.renamed``. The results files keep
    the full set."""
    p = p if isinstance(p, dict) else as_dict(p)
    defaults, renamed = labels.defaults(str(method))
    groups: dict = {}
    for k, v in p.items():
        name = renamed.get(k, k)
        if name in defaults and labels.same(v, defaults[name]) and k not in keep and name not in keep:
            continue
        group, _, short = name.partition(".") if "." in name else ("", "", name)
        groups.setdefault(group, []).append((short, v))
    return sorted(groups.items(), key=lambda g: g[0] != "")


def swept_params(df) -> dict:
    """{method: names of the parameters that take more than one value among its rows}: a table shows
    them in every row of the method, even where a row has the default value."""
    return labels.swept_params([{"method": m, "params": p if isinstance(p, dict) else as_dict(p)}
                                for m, p in zip(df["method"], df["params"])])


def _params_str(p, method=None, sep=" · ", keep=()) -> str:
    """Non-default parameters as text: ``directions=64 · structure: source=peel, depth=4``."""
    parts = []
    for group, items in shown_params(method, p, keep):
        txt = ", ".join(f"{k}={labels.fmt_value(v)}" for k, v in items)
        parts.append(f"{group}: {txt}" if group else txt)
    return sep.join(parts) if parts else "defaults"


def _row_params(r, swept: dict, sep=" · ") -> str:
    return _params_str(r["params"], r["method"], sep, swept.get(r["method"], ()))


def esc(s) -> str:
    """HTML-escaped text of any value (quotes too, so it is safe inside attributes)."""
    return html.escape("" if s is None else str(s), quote=True)


def url(rel: str) -> str:
    """A relative path as an escaped, percent-encoded URL (no scheme, stays inside the folder)."""
    return esc(urllib.parse.quote(str(rel).replace("\\", "/"), safe="/-_.~"))


def _md(s) -> str:
    return str(s).replace("|", "\\|").replace("\n", " ")


# --------------------------------------------------------------------------------------------------
# machine header


def machines(df) -> list[dict]:
    """Distinct (run, machine, commit) combinations in the table, in order of appearance."""
    seen, out = set(), []
    for _, r in df.iterrows():
        key = (r.get("run_id"), r.get("machine_key"), r.get("commit"))
        if key in seen:
            continue
        seen.add(key)
        m = {k: r.get(k) for k, _ in MACHINE_FIELDS}
        dirty = r.get("dirty")
        commit = r.get("commit") or "unknown"
        m["commit"] = f"{commit}{' (dirty: uncommitted changes)' if dirty is True or str(dirty) == 'True' else ''}"
        m["run id"] = r.get("run_id")
        m["time (UTC)"] = r.get("time")
        m["suite"] = r.get("suite")
        out.append(m)
    return out


# --------------------------------------------------------------------------------------------------
# summary.md


def boards(df) -> list:
    """The leaderboards of the run (:mod:`ldbench.reports.leaderboard`): PSNR, with the non-default
    parameters of each configuration as the tables show them."""
    swept = swept_params(df)
    return leaderboards(df, image_rows(df), lambda r: _row_params(r, swept))


BOARD_NOTE = ("Ranked by PSNR against the same reference, best first; ★ = Pareto-optimal on PSNR and time "
              "(no other configuration of the board is as fast and as accurate, and better in one). Rows that "
              "failed are not ranked.")


def _board_md(b) -> list:
    lines = [f"### {_md(b.scene)} · {_md(b.effect)} · {b.size.replace('x', '×')}", "",
             "| rank | method | params (non-default) | PSNR dB | total ms | memory MB | Pareto |",
             "|---|---|---|---|---|---|---|"]
    for e in b.entries:
        rank = str(e.rank) if e.rank is not None else f"– ({_md(e.status)})"
        lines.append(f"| {rank} | {_md(e.method)} | {_md(e.params)} | {_fmt(e.value)} | {_fmt(e.total_ms)} | "
                     f"{_fmt(e.memory_mb, 1)} | {'★' if e.pareto else ''} |")
    return lines + [""]


def _device_line(m: dict) -> str:
    """The machine a run's rows were measured on; a scored answer (``device = external``) was rendered
    outside ldbench, so no GL renderer, driver or CPU of ldbench's is known for it."""
    known = {k: _known(m.get(k)) for k in ("device", "gl_renderer", "gl_version", "driver", "cpu", "gpu_name")}
    if known["device"] == "external":
        return ("- device: **external**: the answer was rendered outside ldbench (`ldbench score`); its time "
                "and memory are those the answer states")
    return (f"- device: **{known['device'] or '–'}** — {known['gl_renderer'] or '–'} ({known['gl_version'] or '–'}); "
            f"driver {known['driver'] or '–'}; CPU {known['cpu'] or '–'}; GPU {known['gpu_name'] or '–'}")


def _known(v):
    """``v``, or None where the table holds no value (None, NaN, an empty string)."""
    return None if v is None or (isinstance(v, float) and math.isnan(v)) or v == "" else v


def write_summary(run_dir: Path, df, figs=(), grids=()) -> Path:
    lines = ["# ldbench run", ""]
    for m in machines(df):
        lines += [f"- run: `{m['run id']}`, suite `{m['suite']}`, commit `{m['commit']}`, {m['time (UTC)']}",
                  _device_line(m)]
    lines.append("")
    if (df["device"] == "cpu-software").any():
        lines += ["> Times are wall clock on a software rasterizer (llvmpipe), not GPU times.", ""]
    bs = boards(df)
    if bs:
        lines += ["## Leaderboard", "", BOARD_NOTE, ""]
        for b in bs:
            lines += _board_md(b)
        lines += ["## All rows", ""]
    img = df[image_rows(df)]
    swept = swept_params(df)
    if len(img):
        lines += ["| scene | method | effect | size | params (non-default) | total ms (IQR) | memory MB | PSNR dB | SSIM | FLIP | relMSE | status |",
                  "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for _, r in img.iterrows():
        lines.append(
            f"| {_md(r['scene'])} | {_md(r['method'])} | {_md(r['effect_text'])} | {r['width']}×{r['height']} | "
            f"{_md(_row_params(r, swept))} | {_fmt(r['total_ms'])} ({_fmt(r['total_ms_iqr'])}) | "
            f"{_fmt(r['memory_mb'], 1)} | {_fmt(r['psnr'])} | {_fmt(r['ssim'], 3)} | {_fmt(r['flip'], 3)} | "
            f"{_fmt(r['relmse'], 4)} | {_md(r['status'])} |")
    for name, cols, rows in metric_tables(df):
        lines += ["", f"## Effect `{name}`", "",
                  "| scene | method | effect | size | params (non-default) | total ms | " + " | ".join(cols) + " | status |",
                  "|" + "---|" * (len(cols) + 7)]
        for _, r in rows.iterrows():
            lines.append(f"| {_md(r['scene'])} | {_md(r['method'])} | {_md(r['effect_text'])} | "
                         f"{r['width']}×{r['height']} | {_md(_row_params(r, swept))} | {_fmt(r['total_ms'])} | "
                         + " | ".join(_metric(r, c) for c in cols) + f" | {_md(r['status'])} |")
    if figs:
        lines += ["", "## Figures", ""] + [f"- [{_md(f.title)}]({f.png}) ([PDF]({f.pdf}))" for f in figs]
    if grids:
        lines += ["", "## Image grids", ""] + [f"![{_md(g.title)}]({g.png})" for g in grids if g.png]
    if len(df):
        lines += ["", PARAMS_NOTE]
    if (run_dir / "reproduce.md").is_file():
        lines += ["", "Paper reproduction: [reproduce.md](reproduce.md)"]
    lines += ["", "Full report: [index.html](index.html)"]
    path = run_dir / "summary.md"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


# --------------------------------------------------------------------------------------------------
# HTML

CSS = """
body{font-family:system-ui,-apple-system,"Segoe UI",Helvetica,Arial,sans-serif;margin:24px;color:#222;max-width:1600px}
h1{font-size:1.5em;margin-bottom:4px} h2{border-bottom:1px solid #ccc;padding-bottom:3px;margin-top:32px}
h3{margin-bottom:6px}
table{border-collapse:collapse;font-size:13px}
th,td{border:1px solid #ccc;padding:3px 7px;vertical-align:top}
th{background:#f0f0f0;text-align:left}
td.num{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}
tr.bad td{background:#fff0f0}
.machine th{width:120px}
.warn{background:#fff3cd;border:2px solid #c00;color:#700;padding:8px 12px;margin:12px 0;font-weight:600}
.problems{background:#fde;border:1px solid #c66;padding:6px 12px}
nav a{margin-right:14px}
figure{display:inline-block;margin:8px 16px 16px 0;vertical-align:top}
figure img{max-width:100%;border:1px solid #ddd}
figcaption{font-size:12px;color:#444;max-width:820px}
table.grid td{border:none;text-align:center;font-size:11px;padding:4px}
table.grid img.px{width:200px;height:auto;image-rendering:pixelated;border:1px solid #bbb}
.cap{font-size:11px;color:#333;line-height:1.35}
.muted{color:#777}
.holds{color:#060;font-weight:600} .fails{color:#a00;font-weight:600}
"""

PARAMS_NOTE = ("Params: only those that differ from the adapter's defaults (grouped by the prefix of "
               "dotted names); results.csv and results.parquet keep the full set.")

RESULT_COLUMNS = ("scene", "method", "effect", "size", "params (non-default)", "total ms", "IQR ms", "wall ms",
                  "memory MB", "PSNR dB", "SSIM", "FLIP", "relMSE", "ref spp", "status")


def _asset(name: str) -> str:
    """A viewer asset shipped beside this module (inlined: the page stays one offline file)."""
    text = (Path(__file__).with_name(name)).read_text(encoding="utf-8")
    if "</script" in text.lower() or "</style" in text.lower():
        raise ValueError(f"{name} must not contain a closing script/style tag")
    return text


class _Html:
    def __init__(self):
        self.parts: list[str] = []

    def raw(self, s: str):
        self.parts.append(s)

    def text(self, tag: str, s, cls: str | None = None, **attrs):
        a = "".join(f' {k.rstrip("_")}="{esc(v)}"' for k, v in attrs.items())
        c = f' class="{esc(cls)}"' if cls else ""
        self.parts.append(f"<{tag}{c}{a}>{esc(s)}</{tag}>")

    def __str__(self):
        return "\n".join(self.parts)


def _img(run_dir: Path, rel: str | None, alt: str, cls: str = "") -> str:
    """An <img> for an existing file, else a visible note (never a broken image)."""
    if rel and (run_dir / rel).is_file():
        c = f' class="{esc(cls)}"' if cls else ""
        return f'<img{c} src="{url(rel)}" alt="{esc(alt)}">'
    return f'<span class="muted">[{esc(alt)}: no image]</span>'


def image_rows(df):
    """Rows of image effects (and of effects this version does not know)."""
    reg = registry()
    return [reg[e].output == "image" if e in reg else True for e in df["effect"]]


def metric_tables(df) -> list:
    """[(effect, metric columns, rows)] for every non-image effect in the table: its spec's metrics."""
    out = []
    for name, spec in registry().items():
        rows = df[df["effect"] == name]
        if spec.output != "image" and len(rows):
            out.append((name, [c for c in spec.metrics if c in df.columns], rows))
    return out


def _metric(r, c) -> str:
    v = labels.as_number(r.get(c))
    if v is None:
        return "–"
    if c.endswith("per_s"):
        return f"{v / 1e6:.4g} M"
    return f"{v:.4g}"


def terminal_table(df) -> str:
    """The end-of-run table for the terminal: one block per effect with that effect's own metrics
    (its spec's ``metrics``; PSNR/SSIM for an effect this version does not know) and the non-default
    parameters."""
    import pandas as pd

    if not len(df):
        return "(no rows)"
    d = prepare(df)
    reg = registry()
    swept = swept_params(d)
    blocks = []
    for eff in dict.fromkeys(d["effect"]):
        rows = d[d["effect"] == eff]
        spec = reg.get(eff)
        cols = [c for c in (spec.metrics if spec is not None else ("psnr", "ssim"))
                if c in rows.columns and any(labels.as_number(v) is not None for v in rows[c])]
        table = pd.DataFrame([{"scene": r["scene"], "method": r["method"], "effect": r["effect_text"],
                               "size": r["size"], "params": _row_params(r, swept, "; "),
                               "total ms": _fmt(r["total_ms"]), "memory MB": _fmt(r["memory_mb"], 1),
                               **{c: _metric(r, c) for c in cols}, "status": r["status"]}
                              for _, r in rows.iterrows()])
        with pd.option_context("display.width", 200, "display.max_columns", 40, "display.max_colwidth", 80):
            blocks.append(table.to_string(index=False))
    return "\n\n".join(blocks)


def _metric_tables_html(h: _Html, df):
    swept = swept_params(df)
    for name, cols, rows in metric_tables(df):
        h.raw(f'<h3 id="effect-{esc(name)}">Effect <code>{esc(name)}</code></h3>')
        heads = ["scene", "method", "effect", "size", "params (non-default)", "total ms", "memory MB", *cols, "status"]
        h.raw('<table class="results"><thead><tr>' + "".join(f"<th>{esc(c)}</th>" for c in heads)
              + "</tr></thead><tbody>")
        for _, r in rows.iterrows():
            cells = [(r["scene"], False), (r["method"], False), (r["effect_text"], False),
                     (r["size"].replace("x", "×"), False), (_row_params(r, swept), False),
                     (_fmt(r["total_ms"]), True), (_fmt(r["memory_mb"], 1), True),
                     *[(_metric(r, c), True) for c in cols], (r["status"], False)]
            tr = "<tr>" if r["status"] == "ok" else '<tr class="bad">'
            h.raw(tr + "".join((f'<td class="num">{esc(v)}</td>' if num else f"<td>{esc(v)}</td>")
                               for v, num in cells) + "</tr>")
        h.raw("</tbody></table>")
        spec = get_spec(name)
        h.text("p", f"Reference: {spec.reference_backend}. Columns as defined in ldbench/core/effects/{name}.py "
                    "(rates are fractions of all rays; distance errors are fractions of the scene diagonal; "
                    "M = 10^6 per second).", cls="cap")


def _leaderboard_html(h: _Html, df):
    bs = boards(df)
    if not bs:
        return
    h.raw('<h2 id="leaderboard">Leaderboard</h2>')
    h.text("p", BOARD_NOTE, cls="cap")
    for b in bs:
        h.text("h3", f"{b.scene} · {b.effect} · {b.size.replace('x', '×')}")
        heads = ["rank", "method", "params (non-default)", "PSNR dB", "total ms", "memory MB", "Pareto"]
        h.raw('<table class="results leaderboard"><thead><tr>' + "".join(f"<th>{esc(c)}</th>" for c in heads)
              + "</tr></thead><tbody>")
        for e in b.entries:
            rank = str(e.rank) if e.rank is not None else "–"
            cells = [(rank, True), (e.method, False), (e.params, False), (_fmt(e.value), True),
                     (_fmt(e.total_ms), True), (_fmt(e.memory_mb, 1), True), ("★" if e.pareto else "", False)]
            tr = "<tr>" if e.rank is not None else f'<tr class="bad" title="{esc(e.status)}">'
            h.raw(tr + "".join((f'<td class="num">{esc(v)}</td>' if num else f"<td>{esc(v)}</td>")
                               for v, num in cells) + "</tr>")
        h.raw("</tbody></table>")


def _results_table(h: _Html, df):
    swept = swept_params(df)
    h.raw('<table class="results"><thead><tr>' + "".join(f"<th>{esc(c)}</th>" for c in RESULT_COLUMNS)
          + "</tr></thead><tbody>")
    for _, r in df[image_rows(df)].iterrows():
        ok = r["status"] == "ok"
        cells = [
            (r["scene"], False), (r["method"], False), (r["effect_text"], False),
            (r["size"].replace("x", "×"), False), (_row_params(r, swept), False),
            (_fmt(r["total_ms"]), True), (_fmt(r["total_ms_iqr"]), True), (_fmt(r.get("wall_ms")), True),
            (_fmt(r["memory_mb"], 1), True), (_fmt(r["psnr"]), True), (_fmt(r["ssim"], 3), True),
            (_fmt(r["flip"], 3), True), (_fmt(r["relmse"], 4), True), (_fmt(r.get("ref_spp"), 0), True),
            (r["status"], False),
        ]
        tr = "<tr>" if ok else '<tr class="bad">'
        h.raw(tr + "".join((f'<td class="num">{esc(v)}</td>' if num else f"<td>{esc(v)}</td>")
                           for v, num in cells) + "</tr>")
    h.raw("</tbody></table>")
    h.text("p", "Times: median over the measured frames (IQR: interquartile range); on a GPU the sum of "
                "the stages' GL timer queries, on a software rasterizer wall clock. Memory: GPU buffers "
                "and textures of the method, MB = 2^20 bytes. PSNR/SSIM/FLIP/relMSE over pixels where "
                "the reference hit geometry; exact settings are in results.csv (metric_settings). "
                f"{PARAMS_NOTE}",
           cls="cap")


def _qurl(rel: str | None) -> str | None:
    """A relative path percent-encoded for use as a URL inside the viewer's JSON (not HTML-escaped)."""
    return urllib.parse.quote(str(rel).replace("\\", "/"), safe="/-_.~") if rel else None


def _viewer_data(run_dir: Path, g) -> dict | None:
    """What the viewer (report_viewer.js) needs of one grid: images, maps, value files, colour bars."""
    if not g.width or not g.reference or not (run_dir / g.reference).is_file():
        return None
    items = [{"label": "reference", "png": _qurl(g.reference), "exr": _qurl(g.reference_exr),
              "values": _qurl(g.reference_values)}]
    for c in g.cells:
        if not c.image:
            continue
        items.append({"label": c.label, "png": _qurl(c.image), "exr": _qurl(c.exr), "values": _qurl(c.values),
                      "abs": _qurl(c.error), "signed": _qurl(c.signed), "flip": _qurl(c.flip),
                      "flip_values": _qurl(c.flip_values), "unbiased": _qurl(getattr(c, "unbiased", None))})
    bars = {"abs": {"png": _qurl(g.colorbar), "lo": 0.0, "hi": g.vmax, "label": "|error|"}}
    if g.signed_colorbar:
        bars["signed"] = {"png": _qurl(g.signed_colorbar), "lo": -g.signed_vmax, "hi": g.signed_vmax,
                          "label": "signed error"}
    if g.flip_colorbar:
        bars["flip"] = {"png": _qurl(g.flip_colorbar), "lo": 0.0, "hi": 1.0, "label": "FLIP"}
    if getattr(g, "unbiased_legend", None):  # score --test unbiased: categories, no range
        bars["unbiased"] = {"png": _qurl(g.unbiased_legend), "lo": None, "hi": None,
                            "label": "unbiased test: rejection map"}
    return {"anchor": g.anchor, "title": g.title, "w": int(g.width), "h": int(g.height), "items": items,
            "bars": bars}


def _json_script(data: dict) -> str:
    """Data for the viewer as an inert JSON script element (``<``, ``>``, ``&`` escaped, so no record
    text can close the element)."""
    text = json.dumps(data, ensure_ascii=True, allow_nan=False)
    text = text.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")
    return f'<script type="application/json" class="ldv-data">{text}</script>'


def _thumb(run_dir: Path, rel: str | None, alt: str, anchor: str | None, idx: int, mode: str) -> str:
    """A grid thumbnail: links to the full-size PNG; with the viewer, a click opens it there."""
    img = _img(run_dir, rel, alt, "px")
    if not (rel and (run_dir / rel).is_file()):
        return img
    data = f' data-ldv="{esc(anchor)}" data-idx="{idx}" data-mode="{esc(mode)}"' if anchor else ""
    return f'<a class="ldv-thumb" href="{url(rel)}"{data} title="open in the viewer (full size)">{img}</a>'


def _file_links(run_dir: Path, *rels) -> str:
    out = [f'<a href="{url(r)}">{esc(Path(r).suffix[1:].upper())}</a>' for r in rels if r and (run_dir / r).is_file()]
    return f'<div class="links">{" · ".join(out)}</div>' if out else ""


def _grid_html(h: _Html, run_dir: Path, g) -> bool:
    """One image grid; returns whether it carries viewer data."""
    data = _viewer_data(run_dir, g)
    anchor = g.anchor if data else None
    h.raw(f'<h3 id="{esc(g.anchor)}">{esc(g.title)}</h3>')
    if data:
        h.raw(_json_script(data))
    h.raw('<table class="grid"><tr>')
    h.raw(f'<td>{_thumb(run_dir, g.reference, "reference", anchor, 0, "image")}'
          f'<div class="cap">{esc(g.reference_caption)}</div>{_file_links(run_dir, g.reference, g.reference_exr)}</td>')
    shown = [c for c in g.cells if c.image]
    idx = {id(c): i for i, c in enumerate(shown, start=1)}
    for c in g.cells:
        i = idx.get(id(c), 0)
        h.raw(f'<td>{_thumb(run_dir, c.image, c.label, anchor if i else None, i, "image")}'
              f'<div class="cap"><b>{esc(c.label)}</b></div>{_file_links(run_dir, c.image, c.exr)}</td>')
    h.raw("</tr><tr>")
    vmax_txt = esc(f"{g.vmax:.3g}")
    h.raw(f'<td>{_img(run_dir, g.colorbar, "colour bar of the error maps")}'
          f'<div class="cap">|error| colour scale: 0 … {vmax_txt}</div></td>')
    for c in g.cells:
        cap = "<br>".join(esc(x) for x in c.caption)
        i = idx.get(id(c), 0)
        h.raw(f'<td>{_thumb(run_dir, c.error, c.label + " error map", anchor if i else None, i, "abs")}'
              f'<div class="cap">{cap}</div></td>')
    h.raw("</tr>")
    for attr, bar, cap in (("signed", g.signed_colorbar,
                            f"signed error (test − reference), −{g.signed_vmax:.3g} … +{g.signed_vmax:.3g}"),
                           ("flip", g.flip_colorbar, "FLIP error, 0 … 1")):
        if not bar or not any(getattr(c, attr) for c in g.cells):
            continue
        h.raw(f'<tr><td>{_img(run_dir, bar, "colour bar: " + cap)}<div class="cap">{esc(cap)}</div></td>')
        for c in g.cells:
            i = idx.get(id(c), 0)
            thumb = _thumb(run_dir, getattr(c, attr), f"{c.label} {attr} map", anchor if i else None, i, attr)
            h.raw(f"<td>{thumb}</td>")
        h.raw("</tr>")
    h.raw("</table>")
    links = []
    if g.png and (run_dir / g.png).is_file():
        links.append(f'<a href="{url(g.png)}">grid as PNG</a>')
    if g.pdf and (run_dir / g.pdf).is_file():
        links.append(f'<a href="{url(g.pdf)}">PDF</a>')
    if g.maps_json and (run_dir / g.maps_json).is_file():
        links.append(f'<a href="{url(g.maps_json)}">map ranges (JSON)</a>')
    h.raw(f'<p class="cap">Top: reference and each method (same exposure). Below: absolute error maps on '
          f'one colour scale for the whole grid (0 … {vmax_txt}; 99th percentile of the worst '
          f'method), signed error maps (red: the method is brighter; symmetric range, one per grid) and '
          f'FLIP maps (0 … 1). Click an image to open the viewer (full size, zoom, keyboard flipping, '
          f'values under the cursor). {" · ".join(links)}</p>')
    if g.problems:
        h.raw('<div class="problems">' + "<br>".join(esc(p) for p in g.problems) + "</div>")
    return data is not None


def _reproduce_html(h: _Html, run_dir: Path) -> bool:
    p = run_dir / "reproduce.json"
    if not p.is_file():
        return False
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
    except ValueError:
        return False
    h.raw('<h2 id="reproduce">Paper reproduction</h2>')
    for entry in data if isinstance(data, list) else [data]:
        h.text("h3", f"{entry.get('key')}: {entry.get('title')}")
        h.text("p", f"Published: {entry.get('published_setup')}. Ours: {entry.get('our_setup')}.", cls="cap")
        h.raw("<table><thead><tr>" + "".join(f"<th>{esc(c)}</th>" for c in
              ("row", "paper setup", "our configuration", "quantity", "published", "ours", "ours vs published"))
              + "</tr></thead><tbody>")
        for r in entry.get("rows", []):
            h.raw("<tr>" + "".join((f'<td class="num">{esc(v)}</td>' if i >= 4 else f"<td>{esc(v)}</td>") for i, v in enumerate(
                (r.get("label"), r.get("paper_setup"), r.get("ours_config"), r.get("quantity"),
                 r.get("published"), r.get("ours"), r.get("ratio"))))
                + "</tr>")
        h.raw("</tbody></table>")
        h.raw("<table style=\"margin-top:8px\"><thead><tr>" + "".join(f"<th>{esc(c)}</th>" for c in
              ("claim", "published", "ours", "verdict", "reason", "verdict rule and window"))
              + "</tr></thead><tbody>")
        for c in entry.get("claims", []):
            v = str(c.get("verdict"))
            cls = "holds" if v == "holds" else ("fails" if v.startswith("does not") else "muted")
            h.raw(f"<tr><td>{esc(c.get('text'))}</td><td>{esc(c.get('published'))}</td>"
                  f'<td>{esc(c.get("ours"))}</td><td class="{cls}">{esc(v)}</td>'
                  f'<td class="cap">{esc(c.get("reason") or "")}</td>'
                  f'<td class="cap">{esc(c.get("rule", ""))}</td></tr>')
        h.raw("</tbody></table>")
        premises = entry.get("premises") or []
        if premises:  # apart from the verdicts: our set-up decides them, so they are never judged
            h.text("p", "Premises: the paper's statements that our set-up decides by construction (our numbers "
                        "beside them, never a verdict).", cls="cap")
            h.raw("<table><thead><tr>" + "".join(f"<th>{esc(c)}</th>" for c in
                  ("premise", "published", "ours", "why it cannot fail")) + "</tr></thead><tbody>")
            for c in premises:
                h.raw("<tr>" + "".join(f"<td>{esc(c.get(k))}</td>" for k in ("text", "published", "ours"))
                      + f'<td class="cap">{esc(c.get("why", ""))}</td></tr>')
            h.raw("</tbody></table>")
        for n in entry.get("notes", []):
            h.text("p", n, cls="cap")
    h.raw('<p class="cap"><a href="reproduce.md">reproduce.md</a></p>')
    return True


def write_html(run_dir: Path, df, figs, grids, problems) -> Path:
    h = _Html()
    ms = machines(df)
    title = f"ldbench report — {ms[0]['suite'] if ms else 'empty run'}"
    h.raw("<!DOCTYPE html>")
    h.raw('<html lang="en"><head><meta charset="utf-8">')
    h.raw('<meta name="viewport" content="width=device-width, initial-scale=1">')
    h.text("title", title)
    h.raw(f"<style>{CSS}</style></head><body>")
    h.text("h1", title)
    # machine / commit header: one column per distinct run × machine × commit
    if ms:
        keys = [k for k in ms[0]]
        labels = dict(MACHINE_FIELDS)
        h.raw('<table class="machine"><tbody>')
        for k in keys:
            h.raw(f"<tr><th>{esc(labels.get(k, k))}</th>" + "".join(f"<td>{esc(m.get(k) if m.get(k) is not None else '–')}</td>"
                                                                 for m in ms) + "</tr>")
        h.raw("</tbody></table>")
    if (df["device"] == "cpu-software").any():
        h.text("div", "Warning: device = cpu-software. These times are wall clock on a software "
                      "rasterizer (Mesa llvmpipe on the CPU), not GPU times; compare them only with runs "
                      "on the same machine, never with the papers' GPU numbers.", cls="warn")
    nav = ['<a href="#leaderboard">leaderboard</a>', '<a href="#results">results</a>', '<a href="#figures">figures</a>',
           '<a href="#grids">image grids</a>']
    if (run_dir / "reproduce.json").is_file():
        nav.append('<a href="#reproduce">paper reproduction</a>')
    nav += ['<a href="results.csv">results.csv</a>', '<a href="summary.md">summary.md</a>']
    h.raw("<nav>" + "".join(nav) + "</nav>")
    if problems:
        h.raw('<div class="problems"><b>Report problems</b><br>' + "<br>".join(esc(p) for p in problems) + "</div>")
    _leaderboard_html(h, df)
    _reproduce_html(h, run_dir)
    h.raw('<h2 id="results">Results</h2>')
    if any(image_rows(df)):
        _results_table(h, df)
    _metric_tables_html(h, df)
    h.raw('<h2 id="figures">Figures</h2>')
    if not figs:
        h.text("p", "No figures (no successful rows).", cls="muted")
    for kind, head in (("stages", "Stage-time breakdown"), ("time-vs-param", "Time vs swept parameters"),
                       ("memory-vs-param", "Memory vs swept parameters"), ("quality", "Quality vs time"),
                       ("rays", "Ray queries: accuracy vs rays per second")):
        fs = [f for f in figs if f.kind == kind]
        if not fs:
            continue
        h.text("h3", head)
        for f in fs:
            h.raw(f"<figure>{_img(run_dir, f.png, f.title)}<figcaption>{esc(f.caption)} "
                  f'<a href="{url(f.pdf)}">PDF</a></figcaption></figure>')
    if not any(f.kind.endswith("vs-param") for f in figs):
        swept = sorted({k for ks in swept_params(df).values() for k in ks})
        if swept:
            h.text("p", f"Swept without a numeric axis: {', '.join(swept)} (each configuration's value is in the "
                        "tables, the leaderboard and the figures' labels).", cls="muted")
        else:
            h.text("p", "No parameter is swept in this run (a parameter is swept when it takes more than one "
                        "value within one scene × method × effect).", cls="muted")
    h.raw('<h2 id="grids">Image grids</h2>')
    if not grids:
        h.text("p", "No images.", cls="muted")
    viewer = False
    for g in grids:
        viewer = _grid_html(h, run_dir, g) or viewer
    if viewer:
        h.raw(f"<style>{_asset('report_viewer.css')}</style>")
        h.raw(f"<script>{_asset('report_viewer.js')}</script>")
    h.text("p", "Generated by ldbench report; this folder is self-contained (relative links only).", cls="muted")
    h.raw("</body></html>")
    path = run_dir / "index.html"
    return atomic_write_text(path, str(h) + "\n")


# --------------------------------------------------------------------------------------------------
# entry points


def write_grids(run_dir: Path, df, problems: list | None = None, damaged: list | None = None) -> list:
    """Image grids of a prepared table (one per scene content × effect × size). A grid whose image files are
    damaged (:func:`damaged_images`) is left out: one line in ``problems`` per file, also kept in ``damaged``."""
    problems = [] if problems is None else problems
    damaged = [] if damaged is None else damaged
    grids = []
    # The same image file claimed by several rows means one job overwrote another's image (the runner's
    # file names do not include every job attribute, e.g. the image size or scene parameters).
    users: dict = {}
    for _, r in df[df["status"] == "ok"].iterrows():
        for k in ("image", "reference", "error_exr"):
            rel = r["images"].get(k)
            if rel:
                users.setdefault(rel, set()).add((r["scene_hash"], r["effect_text"], r["size"],
                                                  r["method"] if k != "reference" else "",
                                                  json.dumps(r["params"], sort_keys=True, default=str)
                                                  if k != "reference" else ""))
    shared = {rel for rel, u in users.items() if len(u) > 1}
    budget = {"bytes": VALUES_BUDGET_BYTES}  # the viewer's value files, for all grids together
    for key, rows in grid_groups(df).items():
        bad = damaged_images(run_dir, rows)
        if bad:  # one line per file; the grid is left out, the rest of the report is written
            damaged.extend(f"image file {rel}: {why}" for rel, why in bad)
            problems.extend(damaged[-len(bad):])
            continue
        try:
            g = make_grid(run_dir, key, rows, values_budget=budget)
            clash = sorted({rel for r in rows for rel in (r["images"].get("image"), r["images"].get("reference"),
                                                           r["images"].get("error_exr")) if rel in shared})
            if clash:
                g.problems.append("these image files are shared with other rows of a different configuration, "
                                  "so they may show another job's image (overwritten during the run): "
                                  + ", ".join(clash))
            grids.append(g)
        except Exception as e:  # noqa: BLE001 - report, do not lose the run
            logging.getLogger(__name__).debug("image grid failed", exc_info=True)  # the traceback with -v
            first = (str(e).strip().splitlines() or [""])[0][:300]
            problems.append(f"image grid {key[0]} {key[2]} {key[3]}: {type(e).__name__}: {first}")
    return grids


#: The first bytes of the image files a run holds (the report reads them back into its grids).
IMAGE_MAGIC = {".png": b"\x89PNG\r\n\x1a\n", ".exr": b"\x76\x2f\x31\x01"}


def damaged_images(run_dir: Path, rows) -> list[tuple[str, str]]:
    """(file, why) of every PNG/EXR of the run that the ``rows`` name and that is empty, unreadable or not that
    format (a copy cut short, a full disk): the report says so in one line each instead of failing on it. A
    missing file is the grid's own note (:func:`~ldbench.reports.figures.grids.make_grid`); files outside the
    run (a scored answer's source) are not the report's."""
    out, seen = [], set()
    for r in rows:
        images = r["images"] if isinstance(r["images"], dict) else {}
        for rel in images.values():
            if (not isinstance(rel, str) or rel in seen or Path(rel).is_absolute()
                    or Path(rel).suffix.lower() not in IMAGE_MAGIC):
                continue
            seen.add(rel)
            p = Path(run_dir) / rel
            try:
                with open(p, "rb") as f:
                    head = f.read(8)
            except FileNotFoundError:
                continue
            except OSError as e:
                out.append((rel, e.strerror or type(e).__name__))
                continue
            if not head:
                out.append((rel, "empty (0 bytes)"))
            elif not head.startswith(IMAGE_MAGIC[p.suffix.lower()]):
                out.append((rel, f"not a {p.suffix[1:].upper()} file"))
    return out


def build_report(run_dir, df=None) -> dict:
    """Write every report file; returns ``{"index": Path, "summary": Path, "figures": [...],
    "grids": [...], "problems": [...], "damaged": [...]}`` (``damaged``: the problems that are image files of
    the run that cannot be read, :func:`damaged_images`). ``df`` defaults to the run directory's results."""
    run_dir = Path(run_dir)
    raw = read_results(run_dir) if df is None else df
    df = prepare(raw)
    (run_dir / "figures").mkdir(exist_ok=True)
    problems: list[str] = []
    damaged: list[str] = []
    figs = write_figures(run_dir, df, problems)
    grids = write_grids(run_dir, df, problems, damaged)
    for p in problems:
        print(f"ldbench: warning: report: {p}", file=sys.stderr)
    summary = write_summary(run_dir, df, figs, grids)
    index = write_html(run_dir, df, figs, grids, problems)
    return {"index": index, "summary": summary, "figures": figs, "grids": grids, "problems": problems,
            "damaged": damaged}


def write_report(run_dir) -> Path:
    """Write the report files of ``run_dir``; returns the path of ``index.html``."""
    return build_report(run_dir)["index"]
