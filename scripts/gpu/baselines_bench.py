"""The screen-space baselines against image size, on one GL context: the G-buffer (compute and hardware raster),
GTAO at each of XeGTAO's presets with and without its depth MIP pre-filter (32- and 16-bit levels), and HBAO with
interleaved and deinterleaved access (docs/reference/methods/gtao.md, docs/reference/methods/hbao.md).

    python scripts/gpu/baselines_bench.py OUT_DIR [--sizes 512,800,1024,2048,3840x2160] [--scene SPEC]
        [--d-max D] [--falloff quadratic|step] [--frames 10] [--warmup 3] [--only gbuffer,gtao,hbao]

Each row is the median over --frames frames (after --warmup) of a configuration's stages, timed as the runner
times a frame (ldbench.core.gpu: Gpu.begin_frame / stage / end_frame, GL timer queries on a GPU, wall clock
around glFinish on llvmpipe). A method's cost leaves out its G-buffer (the G-buffer rows time it alone):

  gbuffer  compute | hardware                      the G-buffer pass (GBuffer.render)
  gtao     <preset> none | mip-32 | mip-16          prefilter + gtao + denoise (prefilter: mip only)
  hbao     <sampling> interleaved | deinterleaved   deinterleave + hbao + blur (deinterleave: deinterleaved only);
           fixed = the defaults (8 x 8 samples), pixel_step = aalund2015-fig8's form (one sample every 4 px out
           to the projected radius, clamp 1132 px)

The default scene is aalund2015-fig8's: the atrium at 260,000 triangles, d_max 10.32 m, quadratic fall-off;
another scene (--scene, any `ldbench run --scene` spec) defaults to its own d_max (ldbench.core.scenes.default_d_max).
Writes OUT_DIR/baselines.csv (a row per configuration and size, written as soon as measured) and
OUT_DIR/baselines.png (cost against pixels, log-log, a line proportional to the pixel count beside each
group), and prints the table. On llvmpipe: --sizes 256 --scene cornell --frames 2 --warmup 1 (about a minute).
"""
from __future__ import annotations

import argparse
import csv
import io
import sys
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from ldbench.core.errors import LdbenchError  # noqa: E402
from ldbench.core.files import atomic_write, atomic_write_text, check_output_path, check_replaceable  # noqa: E402

DEFAULT_SIZES = "512,800,1024,2048,3840x2160"
DEFAULT_SCENE = "atrium:triangles=260000"
FIG8_D_MAX = 10.32  # aalund2015-fig8's d_max on the atrium (FIG8_D_MAX, ldbench/reports/reproductions/aalund2015)
GTAO_MODES = {"none": {}, "mip-32": {"prefilter": "mip"}, "mip-16": {"prefilter": "mip", "depth_precision": "16"}}
GTAO_PRESETS = ("low", "medium", "high", "ultra")
HBAO_SAMPLINGS = {"fixed": {}, "pixel_step": {"sampling": "pixel_step", "step_px": 4.0, "steps": 512,
                                              "max_radius_px": 1132.0}}
HBAO_ACCESSES = ("interleaved", "deinterleaved")
STAGES = ("gbuffer", "prefilter", "gtao", "denoise", "deinterleave", "hbao", "blur")
FIELDS = ("device", "scene", "triangles", "d_max", "falloff", "width", "height", "pixels", "kind", "config",
          "frames", "total_ms", *(f"{s}_ms" for s in STAGES))
CSV_HEAD = ",".join(FIELDS).encode()
PNG_TAG = "ldbench scripts/gpu/baselines_bench.py"


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # argparse's own errors: one line, exit 2
        raise LdbenchError(message)


def parse_sizes(text: str) -> list[tuple[int, int]]:
    """``"512,800,3840x2160"``: a side alone is a square."""
    from ldbench.harness.suite import parse_size

    out = []
    for item in (t.strip() for t in text.split(",")):
        out.append(parse_size(f"{item}x{item}" if item.isdigit() else item))
    if not out:
        raise LdbenchError("--sizes: no size given")
    return out


def configs(only: set) -> list[tuple[str, str, Any]]:
    """(kind, config label, a factory of the measured object) in the order measured."""
    from ldbench.methods.gtao import GTAO, GTAOParams
    from ldbench.methods.hbao import HBAO, HBAOParams

    out: list = []
    if "gbuffer" in only:
        # compute: its default (one 64-bit pass where the GPU has the atomics); "compute two-pass": the 32-bit form
        out += [("gbuffer", cfg, kw) for cfg, kw in (("compute", {"raster": "compute"}), ("compute two-pass",
                {"raster": "compute", "vis64": False}), ("hardware", {"raster": "hardware"}))]
    if "gtao" in only:
        out += [("gtao", f"{preset} {mode}", lambda preset=preset, kw=kw: GTAO(GTAOParams.from_dict(
            {"preset": preset, **kw}))) for preset in GTAO_PRESETS for mode, kw in GTAO_MODES.items()]
    if "hbao" in only:
        out += [("hbao", f"{sampling} {access}", lambda kw=kw, access=access: HBAO(HBAOParams(access=access, **kw)))
                for sampling, kw in HBAO_SAMPLINGS.items() for access in HBAO_ACCESSES]
    return out


def measure(gpu, frame, frames: int, warmup: int) -> tuple[dict, int]:
    """Median ms per stage of ``frame()`` (which opens its own stages) over ``frames`` frames after ``warmup``."""
    for _ in range(warmup):
        gpu.begin_frame()
        frame()
        gpu.end_frame()
    runs = []
    for _ in range(frames):
        gpu.begin_frame()
        frame()
        runs.append(gpu.end_frame()[0])
    return {s: float(np.median([r.get(s, 0.0) for r in runs])) for s in runs[0]}, frames


class Rows:
    """baselines.csv, rewritten whole (atomically) after every row: a run cut short keeps what it measured."""

    def __init__(self, path: Path):
        self.path = path
        self.rows: list[dict] = []

    def add(self, row: dict) -> None:
        self.rows.append(row)
        buf = io.StringIO()
        w = csv.DictWriter(buf, fieldnames=FIELDS, restval="", lineterminator="\n")
        w.writeheader()
        w.writerows(self.rows)
        atomic_write_text(self.path, buf.getvalue())


def table(rows: list) -> str:
    sizes = sorted({(r["width"], r["height"]) for r in rows}, key=lambda s: s[0] * s[1])
    groups = list(dict.fromkeys((r["kind"], r["config"]) for r in rows))
    at = {(r["kind"], r["config"], r["width"], r["height"]): r["total_ms"] for r in rows}
    head = f"{'kind':8s} {'config':26s}" + "".join(f"{f'{w}x{h}':>12s}" for w, h in sizes)
    lines = [head, "-" * len(head)]
    for kind, cfg in groups:
        cells = [at.get((kind, cfg, w, h)) for w, h in sizes]
        lines.append(f"{kind:8s} {cfg:26s}" + "".join(f"{c:12.3f}" if c is not None else f"{'-':>12s}" for c in cells))
    return "\n".join(lines) + "\n(ms; a method's stages without its G-buffer)"


def figure(rows: list, path: Path, title: str) -> None:
    """Cost against pixels, one panel per kind, log-log, each with a dotted line proportional to the pixels."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    kinds = list(dict.fromkeys(r["kind"] for r in rows))
    fig, axes = plt.subplots(1, len(kinds), figsize=(5.5 * len(kinds), 4.5), squeeze=False)
    for ax, kind in zip(axes[0], kinds):
        mine = [r for r in rows if r["kind"] == kind]
        cfgs = list(dict.fromkeys(r["config"] for r in mine))
        # colour by the configuration's first word (preset, sampling), line style by the rest (mode, access)
        colours = {c: f"C{i}" for i, c in enumerate(dict.fromkeys(c.split()[0] for c in cfgs))}
        styles = {c: s for c, s in zip(dict.fromkeys(" ".join(c.split()[1:]) for c in cfgs), ("-", "--", ":", "-."))}
        for cfg in cfgs:
            pts = sorted((r["pixels"], r["total_ms"]) for r in mine if r["config"] == cfg)
            ax.plot(*zip(*pts), marker="o", ms=3, lw=1, label=cfg, color=colours[cfg.split()[0]],
                    ls=styles.get(" ".join(cfg.split()[1:]), "-"))
        px = sorted({r["pixels"] for r in mine})
        first = min((r for r in mine if r["pixels"] == px[0]), key=lambda r: r["total_ms"])
        ax.plot(px, [first["total_ms"] * p / px[0] for p in px], color="k", lw=2, alpha=0.3, label="∝ pixels")
        ax.set(xscale="log", yscale="log", xlabel="pixels", ylabel="ms", title=kind)
        ax.grid(True, which="both", lw=0.3)
        ax.legend(fontsize=6)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    atomic_write(path, lambda t: fig.savefig(t, format="png", dpi=110, metadata={"Software": PNG_TAG}))
    plt.close(fig)


def run(args) -> None:
    from ldbench.core.effects import Effect
    from ldbench.core.gpu import Gpu
    from ldbench.core.scenes import default_d_max, load_scene
    from ldbench.methods.base import View
    from ldbench.methods.gbuffer import GBuffer, SceneGeometry

    out = check_output_path(args.out_dir, into=True, flag="OUT_DIR")
    csv_path, png_path = out / "baselines.csv", out / "baselines.png"
    check_replaceable(csv_path, lambda head: head.startswith(CSV_HEAD))
    check_replaceable(png_path, lambda head: head.startswith(b"\x89PNG") and PNG_TAG.encode() in head)
    sizes = parse_sizes(args.sizes)
    only = {k.strip() for k in args.only.split(",") if k.strip()}
    if not only or only - {"gbuffer", "gtao", "hbao"}:
        raise LdbenchError(f"--only: a comma-separated subset of gbuffer,gtao,hbao, got {args.only!r}")
    if args.frames < 1 or args.warmup < 0:
        raise LdbenchError(f"--frames must be >= 1 and --warmup >= 0, got {args.frames} and {args.warmup}")
    d_max = args.d_max
    if d_max is None:
        d_max = FIG8_D_MAX if args.scene == DEFAULT_SCENE else default_d_max(args.scene)[0]
    if not d_max > 0:
        raise LdbenchError(f"--d-max must be > 0, got {d_max}")
    effect = Effect("ao", d_max, args.falloff)

    gpu = Gpu()
    for w, h in sizes:
        gpu.check_image_size(w, h)
    scene = load_scene(args.scene)
    device = gpu.info.get("GL_RENDERER") or "?"
    res = gpu.resources("bench.")
    geo = SceneGeometry(gpu, scene, res)
    print(f"{device}: {args.scene}, {geo.triangles} triangles, ao {args.falloff} d_max {d_max:g}; median of "
          f"{args.frames} frames after {args.warmup}", flush=True)
    rows = Rows(csv_path)
    for kind, cfg, make in configs(only):
        if kind == "gbuffer":
            gbuf = GBuffer(gpu, geo, gpu.resources(f"bench.{cfg}."), **make)
        else:
            method = make()
            method.setup(gpu, scene)
        for w, h in sizes:
            view = View(scene.camera, w, h)
            if kind == "gbuffer":
                def frame(view=view):
                    with gpu.stage("gbuffer"):
                        gbuf.render(view)
            else:
                def frame(view=view):
                    method.frame(view, effect)
            stages, n = measure(gpu, frame, args.frames, args.warmup)
            total = stages["gbuffer"] if kind == "gbuffer" else sum(v for k, v in stages.items() if k != "gbuffer")
            row = {"device": device, "scene": args.scene, "triangles": geo.triangles, "d_max": d_max,
                   "falloff": args.falloff, "width": w, "height": h, "pixels": w * h, "kind": kind, "config": cfg,
                   "frames": n, "total_ms": round(total, 4),
                   **{f"{s}_ms": round(stages[s], 4) for s in STAGES if s in stages}}
            rows.add(row)
            print(f"{kind:8s} {cfg:26s} {w:5d}x{h:<5d} {total:10.3f} ms  "
                  + " ".join(f"{s} {stages[s]:.3f}" for s in STAGES if s in stages), flush=True)
        if kind == "gbuffer":
            gbuf.res.release()
        else:
            method.release()
    print()
    print(table(rows.rows))
    figure(rows.rows, png_path, f"{device}: {args.scene}, ao {args.falloff} d_max {d_max:g}")
    print(f"wrote {csv_path} and {png_path}")


def main(argv=None) -> int:
    ap = _Parser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out_dir", metavar="OUT_DIR")
    ap.add_argument("--sizes", default=DEFAULT_SIZES, help=f"comma-separated N or WxH (default {DEFAULT_SIZES})")
    ap.add_argument("--scene", default=DEFAULT_SCENE, help=f"a scene spec (default {DEFAULT_SCENE})")
    ap.add_argument("--d-max", type=float, default=None, help="AO distance (default: 10.32 on the default scene)")
    ap.add_argument("--falloff", default="quadratic", choices=("step", "quadratic"))
    ap.add_argument("--frames", type=int, default=10)
    ap.add_argument("--warmup", type=int, default=3)
    ap.add_argument("--only", default="gbuffer,gtao,hbao", help="kinds to measure (default: all)")
    try:
        args = ap.parse_args(argv)
        print("python scripts/gpu/baselines_bench.py " + " ".join(sys.argv[1:] if argv is None else argv), flush=True)
        run(args)
    except LdbenchError as e:
        print(f"baselines_bench: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
