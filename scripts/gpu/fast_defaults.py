"""Fast defaults against the paper presets (docs/reference/methods/fast_builds.md, "Defaults"): each workload run twice in one
process-per-run sequence on the same GPU — the configuration of the previous defaults (``preset = paper``, or
the variant it replaces) and today's default — with its stage times, image quality against the same Mitsuba
reference, and the bound its build reaches.

    python scripts/gpu/fast_defaults.py OUT_DIR [--dry] [--only ROW,ROW] [--labels LABEL;LABEL]

Rows: fig8 (aalund2015 Figure 8 frame), cdi (the CDI build, 169 x 64², atrium), fig10 (aalund2015 Figure 10
frame), hbao (800², 8 x 8), ldi (96 LDIs of 128², atrium); --labels: only the runs of these labels
(separated by ";"). Writes
OUT_DIR/runs/<row>-<label>/ (each a `ldbench run`), OUT_DIR/fast-defaults.csv and OUT_DIR/fast-defaults.md.
The bound: the structure's bytes / (build time x the copy bandwidth in OUT_DIR/bandwidth.csv, written by
``fast_builds_bench.py OUT_DIR bandwidth``), and the raster rate (triangles x layers / build time).
--dry: a 32² frame of a 4000-triangle atrium and small structures (llvmpipe).
"""
from __future__ import annotations

import csv
import subprocess
import sys
from pathlib import Path

import pandas as pd

from ldbench.harness import read_results

D_MAX = ["--falloff", "quadratic", "--d-max", "10.32"]
FIG8 = ["--set", "ldm.directions=512", "--set", "ldm.resolution=200"]
FIG10 = FIG8 + ["--set", "ldm.indirect.photons=100", "--set", "ldm.indirect.footprint_scale=1.0"]
#: row -> (method, effect, common args, {label: extra args}); the first label is "before"
ROWS = {
    "fig8": ("ldm", "ao", D_MAX + FIG8, {"paper": ["--set", "ldm.preset=paper", "--set", "ldm.gbuffer=hardware"],
                                         "default, hardware G-buffer": ["--set", "ldm.gbuffer=hardware"],
                                         "default": [],
                                         "default, linear sort": ["--set", "ldm.structure.layout=linear", "--set",
                                                                  "ldm.structure.assembly=sort"],
                                         "default, long triangles by the hardware": [
                                             "--set", "ldm.structure.splat_large=raster"],
                                         "default, linear sort, long triangles by the hardware": [
                                             "--set", "ldm.structure.layout=linear", "--set",
                                             "ldm.structure.assembly=sort", "--set",
                                             "ldm.structure.splat_large=raster"],
                                         "default, no splat queue, splat_batch 8, map dispatches": [
                                             "--set", "ldm.structure.splat_queue=false", "--set",
                                             "ldm.structure.splat_batch=8", "--set",
                                             "ldm.trace.map_schedule=dispatches"],
                                         "default, no splat queue": ["--set", "ldm.structure.splat_queue=false"],
                                         "default, splat_batch 8": ["--set", "ldm.structure.splat_batch=8"],
                                         "default, map dispatches": ["--set", "ldm.trace.map_schedule=dispatches"],
                                         "default, aggregate": ["--set", "ldm.structure.aggregate=true"],
                                         "default, splat_sort": ["--set", "ldm.structure.splat_sort=true"],
                                         "default, no splat_sort": ["--set", "ldm.structure.splat_sort=false"],
                                         "default, prefetch 4": ["--set", "ldm.trace.prefetch=4"],
                                         "default, prefetch 8": ["--set", "ldm.trace.prefetch=8"],
                                         "default, prefetch 16": ["--set", "ldm.trace.prefetch=16"],
                                         **{f"default, map_batch {m}": ["--set", f"ldm.trace.map_batch={m}"]
                                            for m in (0, 8, 16, 32, 128)},
                                         "default, linear sort, map_batch 32": [
                                             "--set", "ldm.structure.layout=linear", "--set",
                                             "ldm.structure.assembly=sort", "--set", "ldm.trace.map_batch=32"]}),
    "cdi": ("cdi-vpl", "vpl_range", [], {"paper": ["--set", "cdi-vpl.preset=paper"], "default": [],
                                         "default, max_list 64": ["--set", "cdi-vpl.structure.max_list=64"],
                                         "default, max_list 128": ["--set", "cdi-vpl.structure.max_list=128"],
                                         "splat+sort": ["--set", "cdi-vpl.structure.source=splat"],
                                         "splat+sort, long triangles by the hardware": [
                                             "--set", "cdi-vpl.structure.source=splat", "--set",
                                             "cdi-vpl.structure.splat_large=raster"]}),
    "fig10": ("ldm", "indirect", FIG10, {"paper": ["--set", "ldm.preset=paper"], "default": [],
                                         "default, splat_sort": ["--set", "ldm.structure.splat_sort=true"],
                                         "default, no splat_sort": ["--set", "ldm.structure.splat_sort=false"],
                                         "default, long triangles by the hardware": [
                                             "--set", "ldm.structure.splat_large=raster"],
                                         "default, blended splats": ["--set", "ldm.indirect.splat=blend"]}),
    "hbao": ("hbao", "ao", D_MAX, {"hardware G-buffer": ["--set", "hbao.gbuffer=hardware"], "default": []}),
    "ldi": ("ldi", "indirect", ["--set", "ldi.directions=96", "--set", "ldi.resolution=128"],
            {"paper": ["--set", "ldi.preset=paper"], "default": [],
             "default, long triangles by the hardware": ["--set", "ldi.structure.splat_large=raster"]}),
}
#: --dry: small structures instead of the papers' sizes
DRY = {"ldm.directions=512": "ldm.directions=16", "ldm.resolution=200": "ldm.resolution=32",
       "ldi.directions=96": "ldi.directions=24", "ldi.resolution=128": "ldi.resolution=32"}
BUILD_STAGES = ("count", "build", "sort", "emit", "scan", "fill", "peel", "scatter", "canon")


def bandwidth(out: Path) -> float:
    f = out / "bandwidth.csv"
    return float(next(csv.DictReader(open(f)))["bytes_per_s"]) if f.exists() else float("nan")


def main():
    out, dry = Path(sys.argv[1]), "--dry" in sys.argv
    only = sys.argv[sys.argv.index("--only") + 1].split(",") if "--only" in sys.argv else list(ROWS)
    size = ["--size", "32x32", "--spp", "4", "--warmup", "0", "--frames", "1"] if dry else \
        ["--size", "800x800", "--spp", "64", "--warmup", "3", "--frames", "10"]
    labels_only = sys.argv[sys.argv.index("--labels") + 1].split(";") if "--labels" in sys.argv else None
    tris = "4000" if dry else "260000"
    bw = bandwidth(out)
    rows = []
    for row in only:
        method, effect, common, labels = ROWS[row]
        for label, extra in labels.items():
            if labels_only is not None and label not in labels_only:
                continue
            args = [DRY.get(a, a) for a in common] if dry else list(common)
            sz = ["--size", "400x400"] + size[2:] if row == "ldi" and not dry else size
            d = out / "runs" / f"{row}-{label.replace(' ', '').replace(',', '-')}"
            cmd = [sys.executable, "-m", "ldbench.harness.cli", "run", "--scene", "atrium", "--scene-set",
                   f"triangles={tris}", "--method", method, "--effect", effect, *sz, *args, *extra, "--out", str(d),
                   "--no-report", "--no-progress", "-q"]
            print("$", " ".join(cmd[1:]), flush=True)
            p = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
            if p.returncode != 0:
                print(p.stderr[-2000:], flush=True)
                rows.append(dict(row=row, label=label, status=f"rc {p.returncode}"))
                continue
            r = read_results(d).iloc[0]  # d.name: the run, for scripts/gpu/results_page.py
            st = dict(r.stage_ms)
            build = sum(v for k, v in st.items() if k in BUILD_STAGES)
            sbytes = r.get("structure_bytes")
            sbytes = 0.0 if sbytes is None or pd.isna(sbytes) else float(sbytes)
            c = r.get("counters") if isinstance(r.get("counters"), dict) else {}
            rows.append(dict(
                row=row, label=label, run=d.name, total_ms=r.total_ms, build_ms=build,
                stages=" ".join(f"{k} {v:.3f}" for k, v in st.items()),
                psnr=r.get("psnr"), range_err_p50=r.get("range_err_p50"), hit_agreement=r.get("hit_agreement"),
                structure_mb=sbytes / 1e6, fragments=c.get("fragments"),
                bandwidth_fraction=sbytes / (build * 1e-3 * bw) if build > 0 and sbytes and bw == bw else "",
                status=r.status, device=r.get("device")))
            print(row, label, f"total {r.total_ms:.3f} ms, build {build:.3f} ms:", rows[-1]["stages"], flush=True)
    fields = sorted({k for r in rows for k in r}, key=lambda k: list(rows[0]).index(k) if k in rows[0] else 99)
    with open(out / "fast-defaults.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields, restval="")
        w.writeheader()
        w.writerows(rows)

    def fmt(v):
        return f"{v:.4g}" if isinstance(v, float) else ("" if v is None else str(v))

    cols = ["row", "label", "total_ms", "build_ms", "stages", "psnr", "range_err_p50", "hit_agreement",
            "structure_mb", "bandwidth_fraction", "status"]
    md = [f"copy bandwidth: {bw / 1e9:.0f} GB/s" if bw == bw else "copy bandwidth: not measured", "",
          "| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    md += ["| " + " | ".join(fmt(r.get(k)) for k in cols) + " |" for r in rows]
    (out / "fast-defaults.md").write_text("\n".join(md) + "\n")
    print("\n".join(md))


if __name__ == "__main__":
    main()
