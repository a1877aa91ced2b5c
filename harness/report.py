"""Reports of a run directory: ``summary.md`` and one image grid per scene × effect.

The grid shows the reference, each method's image, and each method's error map (one colour scale per
grid, with a colour bar), with the metric values in the captions.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np


def _fmt(v, nd=2):
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return "–"
    if isinstance(v, float) and math.isinf(v):
        return "∞"
    return f"{v:.{nd}f}" if isinstance(v, float) else str(v)


def _params_str(p) -> str:
    p = p if isinstance(p, dict) else json.loads(p or "{}")
    return ", ".join(f"{k}={v}" for k, v in p.items())


def write_summary(run_dir: Path, df) -> Path:
    lines = ["# ldbench run", ""]
    if len(df):
        r0 = df.iloc[0]
        lines += [f"- run: `{r0.get('run_id')}`, suite `{r0.get('suite')}`, commit `{r0.get('commit')}`"
                  f"{' (dirty)' if r0.get('dirty') else ''}",
                  f"- device: **{r0.get('device')}** — {r0.get('gl_renderer')} ({r0.get('gl_version')}); "
                  f"CPU {r0.get('cpu')}", ""]
        if r0.get("device") == "cpu-software":
            lines += ["> Times are wall clock on a software rasterizer (llvmpipe), not GPU times.", ""]
    lines += ["| scene | method | effect | size | params | total ms (IQR) | memory MB | PSNR dB | SSIM | FLIP | relMSE | status |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for _, r in df.iterrows():
        eff = r["effect"]
        ep = r.get("effect_params")
        ep = ep if isinstance(ep, dict) else json.loads(ep or "{}")
        if eff == "ao":
            eff = f"ao ({ep.get('falloff')}, d_max={ep.get('d_max')})"
        mem = r.get("memory_bytes")
        lines.append(
            f"| {r['scene']} | {r['method']} | {eff} | {r['width']}×{r['height']} | {_params_str(r.get('params'))} | "
            f"{_fmt(r.get('total_ms'))} ({_fmt(r.get('total_ms_iqr'))}) | "
            f"{_fmt(mem / 2**20 if isinstance(mem, (int, float)) and not math.isnan(mem) else None, 1)} | "
            f"{_fmt(r.get('psnr'))} | {_fmt(r.get('ssim'), 3)} | {_fmt(r.get('flip'), 3)} | "
            f"{_fmt(r.get('relmse'), 4)} | {r.get('status')} |")
    grids = sorted((run_dir / "figures").glob("grid-*.png")) if (run_dir / "figures").exists() else []
    if grids:
        lines += ["", "## Image grids", ""] + [f"![{g.stem}](figures/{g.name})" for g in grids]
    path = run_dir / "summary.md"
    path.write_text("\n".join(lines) + "\n")
    return path


def write_grids(run_dir: Path, df) -> list[Path]:
    """One PNG per (scene, effect, size): reference | methods (top), error maps (bottom)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from references.exr import read_exr
    from . import metrics

    out = []
    ok = df[df["status"] == "ok"]
    if not len(ok):
        return out
    (run_dir / "figures").mkdir(exist_ok=True)
    keyf = lambda r: (r["scene"], json.dumps(r["effect_params"], sort_keys=True) if isinstance(r["effect_params"], dict) else r["effect_params"], r["width"], r["height"])
    groups: dict = {}
    for _, r in ok.iterrows():
        groups.setdefault(keyf(r), []).append(r)
    for (scene, _, w, h), rows in groups.items():
        ims = [r["images"] if isinstance(r["images"], dict) else json.loads(r["images"]) for r in rows]
        ref = _load(run_dir, ims[0]["reference"].replace(".png", ".exr"), read_exr)
        tests = [_load(run_dir, im["exr"], read_exr) for im in ims]
        errs = [_load(run_dir, im["error_exr"], read_exr)[..., 0] for im in ims]  # masked by the runner
        vmax = max(float(np.percentile(e, 99)) for e in errs) or 1e-6
        n = len(rows) + 1
        fig, axes = plt.subplots(2, n, figsize=(2.6 * n, 5.6), squeeze=False)
        scale = 1.0 if rows[0]["effect"] == "ao" else float(np.percentile(ref, 99) or 1.0)
        axes[0, 0].imshow(metrics.to_srgb8(_rgb(ref) / scale))
        axes[0, 0].set_title(f"reference\n{rows[0].get('ref_spp')} spp", fontsize=8)
        axes[1, 0].axis("off")
        im = None
        for i, (r, t, e) in enumerate(zip(rows, tests, errs), start=1):
            axes[0, i].imshow(metrics.to_srgb8(_rgb(t) / scale))
            title = r["method"] + (f"\n{_params_str(r['params'])}" if len(rows) > 1 else "")
            axes[0, i].set_title(title[:60], fontsize=7)
            im = axes[1, i].imshow(e, cmap="magma", vmin=0, vmax=vmax)
            axes[1, i].set_title(f"PSNR {_fmt(r['psnr'])} dB  SSIM {_fmt(r['ssim'], 3)}\n"
                                 f"FLIP {_fmt(r['flip'], 3)}  {_fmt(r['total_ms'])} ms", fontsize=7)
        for a in axes.flat:
            a.set_xticks([]), a.set_yticks([])
        if im is not None:
            fig.colorbar(im, ax=list(axes[1, 1:]), fraction=0.046, pad=0.02, label="|error|")
        eff = rows[0]["effect"]
        fig.suptitle(f"{scene} — {eff} — {w}×{h}", fontsize=10)
        ref_stem = Path(ims[0]["reference"]).stem.removeprefix("reference-")
        tag = "".join(c if c.isalnum() or c in "-." else "_" for c in f"{scene}-{ref_stem}")
        path = run_dir / "figures" / f"grid-{tag}.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        out.append(path)
    return out


def _rgb(a):
    return np.repeat(a, 3, -1) if a.shape[-1] == 1 else a[..., :3]


def _load(run_dir, rel, read_exr):
    ch = read_exr(str(run_dir / rel))
    keys = [k for k in ("R", "G", "B") if k in ch] or [k for k in ("Y",) if k in ch] or list(ch)[:1]
    return np.stack([ch[k] for k in keys], -1).astype(np.float32)


def write_report(run_dir) -> Path:
    """Write the report files of ``run_dir``; returns the main page's path."""
    from .records import read_results

    run_dir = Path(run_dir)
    df = read_results(run_dir)
    write_grids(run_dir, df)
    return write_summary(run_dir, df)
