#!/usr/bin/env bash
# GPU measurements of niessner2010 (the ldi adapter): Table 1 on Sibenik (rays/s of diffuse, glossy
# and soft-shadow rays, 512² and 128² LDIs, 96/150/384 LDIs) with hit agreement, p95 distance error and
# Mitsuba's rays/s on the same rays; the build (depth peeling + GPU compaction) and memory rows; the
# premise check (LDI rays >= 2x the oracle at >= 0.95 hit agreement, diffuse, 128²); indirect light on
# cornell and atrium 260k at 800² (stage times: gbuffer, shadow, peel, scan, scatter, canon, trace,
# filter; memory; PSNR/SSIM/FLIP against Mitsuba), glossy indirect and soft shadows on atrium.
#
# Usage, from the project root with its Python environment set up (no network needed; $PYTHON, default python3):
#     OUT=/some/dir bash scripts/gpu/ldi-build-trace.sh /path/to/scene-mirror      # the mirror holds sibenik/
# Outputs (Markdown, CSV, PNG, logs; < 5 MB) under "$OUT/ldi-build-trace/"; the summary also on stdout.
# Every step runs under `timeout` (the limits add up to 5 min) and a failing step loses only its own rows.
# LDBENCH_GPU_DRY=1: a CPU-sized dry run (scale "ci", 32² images, small atrium) to test the script on llvmpipe.
set -u
MIRROR="${1:-}"
O="${OUT:-/tmp/ldbench-gpu}/ldi-build-trace"
mkdir -p "$O"
: > "$O/log.txt"
W="$(mktemp -d "${TMPDIR:-/tmp}/ldi-build-trace.XXXXXX")"
export LDBENCH_CACHE="${LDBENCH_CACHE:-$W/cache}"
export LDBENCH_SCENES="${LDBENCH_SCENES:-$W/scenes}"
PY="${PYTHON:-python3}"
LDB="${LDBENCH:-$PY -m ldbench.harness.cli}"
DRY="${LDBENCH_GPU_DRY:-0}"
SCALE=paper SIZE=800x800 SPP=1024 ATRIUM=260000 FRAMES="--warmup 2 --frames 5" K=1
if [ "$DRY" = 1 ]; then SCALE=ci SIZE=32x32 SPP=64 ATRIUM=4000 FRAMES="--warmup 0 --frames 3" K=6; fi
step() {  # step SECONDS NAME CMD...: run with a time limit (x K), log, continue on failure
    local t=$(($1 * K)) name=$2; shift 2
    echo "== $name: $*" >> "$O/log.txt"
    local t0=$SECONDS
    timeout "$t" "$@" > "$O/$name.log" 2>&1
    local rc=$?
    echo "   $name: rc=$rc in $((SECONDS - t0)) s" | tee -a "$O/log.txt"
}

nvidia-smi --query-gpu=name,driver_version,clocks.max.sm,memory.total --format=csv > "$O/gpu.txt" 2>&1
step 10 probe $PY -c "from ldbench.core.gpu import Gpu; g = Gpu(); print(g.info, g.device, g.ctx.info['GL_MAX_SHADER_STORAGE_BLOCK_SIZE'])"
step 15 fetch $LDB scenes fetch sibenik --from "$MIRROR"
# the structure tests on this GPU: peel == one-pass build bit for bit, compaction == cumsum, walk == CPU DDA
step 20 tests $PY -m pytest -q -p no:cacheprovider tests/test_ldi.py -k "identical or cpu_raster or cumsum or cpu_dda or six_cube"

# 1. Table 1 (+ build and memory rows): the bundled reproduction's jobs at scale $SCALE, in four parts (a part
#    that fails or times out loses only its rows); evaluated together in the summary
cat > "$W/part.py" <<'EOF'
import dataclasses, sys
from ldbench.reports.reproduce import get_entry, scale_suite, suite_file
from ldbench.harness.runner import run_jobs
from ldbench.harness.suite import load_suite

part, out, scale = sys.argv[1], sys.argv[2], sys.argv[3]
entry = get_entry("niessner2010-table1")
suite = scale_suite(load_suite(suite_file(entry)), entry.scales[scale])
grid = lambda j: dict(j.params).get("prebuild") and j.effect.rays_per_pixel == 16  # noqa: E731
jobs = [j for j in suite.jobs if (grid(j) and j.effect.ray_kind == part) or (part == "build" and not grid(j))]
print(f"{part}: {len(jobs)} jobs")
run_jobs(dataclasses.replace(suite, jobs=jobs), out, progress=False, report=False)
EOF
step 30 table1-diffuse $PY "$W/part.py" diffuse "$W/table1-diffuse" "$SCALE"
step 30 table1-shadow $PY "$W/part.py" shadow "$W/table1-shadow" "$SCALE"
step 30 table1-glossy $PY "$W/part.py" glossy "$W/table1-glossy" "$SCALE"
step 45 table1-build $PY "$W/part.py" build "$W/table1-build" "$SCALE"

# 2. indirect light at 800² (the paper's pipeline: 8 rays per pixel, 11×11 Gaussian, 150 LDIs of 128²), the LDIs
#    depth-peeled in every frame; on atrium 260k also the one-pass build (peeling's raster passes grow with the
#    depth complexity), then glossy indirect and soft shadows on the one-pass build
step 20 indirect-cornell $LDB run --scene cornell --method ldi --effect indirect --size "$SIZE" --spp "$SPP" $FRAMES \
    --out "$W/indirect-cornell" --no-progress --no-report
step 30 indirect-atrium-peel $LDB run --scene "atrium:triangles=$ATRIUM" --method ldi --effect indirect --size "$SIZE" \
    --spp "$SPP" --warmup 0 --frames 2 --out "$W/indirect-atrium-peel" --no-progress --no-report
step 20 indirect-atrium $LDB run --scene "atrium:triangles=$ATRIUM" --method ldi --effect indirect --size "$SIZE" \
    --spp "$SPP" $FRAMES --set ldi.build=single_pass --out "$W/indirect-atrium" --no-progress --no-report
step 15 glossy-atrium $LDB run --scene "atrium:triangles=$ATRIUM" --method ldi --effect glossy_indirect --size "$SIZE" \
    --spp "$SPP" $FRAMES --set ldi.build=single_pass --out "$W/glossy-atrium" --no-progress --no-report
step 15 soft-atrium $LDB run --scene "atrium:triangles=$ATRIUM" --method ldi --effect soft_shadows --effect-set light_radius=0.5 \
    --size "$SIZE" --spp "$SPP" $FRAMES --set ldi.build=single_pass --out "$W/soft-atrium" --no-progress --no-report

# 3. summary: tables, verdicts, a figure
step 20 summary $PY - "$W" "$O" "$SCALE" <<'EOF'
import math, shutil, sys
from pathlib import Path

import pandas as pd

from ldbench.harness.records import read_results
from ldbench.reports.reproduce import evaluate, format_markdown, get_entry
from ldbench.reports.reproductions.niessner2010 import premise

work, out, scale = Path(sys.argv[1]), Path(sys.argv[2]), sys.argv[3]


def load(name):
    try:
        return read_results(work / name)
    except Exception as e:  # noqa: BLE001 - a step that failed or timed out: say so, keep the others
        print(f"{name}: no results ({e})")
        return None


def md(df):
    f = lambda v: (f"{v:.4g}" if isinstance(v, float) else str(v))  # noqa: E731
    return "\n".join(["| " + " | ".join(map(str, df.columns)) + " |", "|" + "---|" * len(df.columns)]
                     + ["| " + " | ".join(f(v) for v in row) + " |" for row in df.itertuples(index=False)])


def stages(r, names):
    s = r["stage_ms"] if isinstance(r["stage_ms"], dict) else {}
    return {n: s.get(n, math.nan) for n in names}


C = lambda r, k: (r["counters"] or {}).get(k) if isinstance(r["counters"], dict) else None  # noqa: E731
lines, dev = [], "?"
parts = [df for df in (load(f"table1-{p}") for p in ("diffuse", "glossy", "shadow", "build")) if df is not None]
t1 = pd.concat(parts, ignore_index=True) if parts else None
if t1 is not None and len(t1):
    dev = f"{t1.device.iloc[0]}: {t1.gpu_name.iloc[0] or t1.gl_renderer.iloc[0]}"
    res = evaluate(get_entry("niessner2010-table1"), t1, scale)
    (out / "table1-reproduce.md").write_text(format_markdown(res))
    rows = []
    for _, r in t1.iterrows():
        p, e = r["params"], r["effect_params"]
        rows.append({"kind": e.get("ray_kind"), "rpp": e.get("rays_per_pixel"), "LDIs (6k²)": p.get("directions"),
                     "stored": C(r, "ldis"), "res": p.get("resolution"), "build": p.get("build"),
                     "prebuild": p.get("prebuild"), "rays": r.rays, "M rays/s": r.rays_per_s / 1e6,
                     "oracle M rays/s": r.oracle_rays_per_s / 1e6, "LDI/oracle": r.rays_per_s / r.oracle_rays_per_s,
                     "hit agreement": r.hit_agreement, "p95 dist err": r.dist_err_p95,
                     "crossings mean": C(r, "crossings_mean"), "crossings max": C(r, "crossings_max"),
                     **{f"{k} ms": v for k, v in stages(r, ("peel", "scan", "scatter", "canon", "count", "fill",
                                                            "sort", "trace")).items()},
                     "total ms": r.total_ms, "peel layers": C(r, "peel_layers"), "fragments": C(r, "fragments"),
                     "LDI MB": (C(r, "ldi_bytes") or 0) / 2**20, "memory MB": r.memory_bytes / 2**20,
                     "status": r.status})
    tab = pd.DataFrame(rows)
    tab.to_csv(out / "table1.csv", index=False)
    lines += ["## Table 1 grid, build and memory rows", "", md(tab), "", "## Claims (two rows each)", ""]
    lines += [f"- {c['text']}: {c['ours']} → **{c['verdict']}**" for c in res["claims"]]
    lines += ["", "## The premise and the published absolute ranges", ""]
    lines += [f"- {c['text']}: {c['ours']} → **{c['verdict']}**" for c in premise(t1, scale)] + [""]
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        g = tab[tab.rpp == 16].sort_values(["kind", "res", "LDIs (6k²)"])
        lab = [f"{k[:4]} {r} {n}" for k, r, n in zip(g.kind, g.res, g["LDIs (6k²)"])]
        fig, ax = plt.subplots(2, 1, figsize=(11, 6), sharex=True)
        x = range(len(g))
        ax[0].bar([i - 0.2 for i in x], g["M rays/s"], 0.4, label="LDI (ours)")
        ax[0].bar([i + 0.2 for i in x], g["oracle M rays/s"], 0.4, label="Mitsuba oracle, same rays")
        ax[0].set_yscale("log")
        ax[0].set_ylabel("M rays/s")
        ax[0].legend()
        ax[1].plot(list(x), g["hit agreement"], "o-")
        ax[1].set_ylabel("hit agreement")
        ax[1].set_xticks(list(x), lab, rotation=60, fontsize=7)
        fig.tight_layout()
        fig.savefig(out / "table1.png", dpi=90)
    except Exception as e:  # noqa: BLE001
        print(f"figure: {e}")
rows = []
for name in ("indirect-cornell", "indirect-atrium-peel", "indirect-atrium", "glossy-atrium", "soft-atrium"):
    df = load(name)
    if df is None:
        continue
    dev = dev if dev != "?" else f"{df.device.iloc[0]}: {df.gpu_name.iloc[0] or df.gl_renderer.iloc[0]}"
    for _, r in df.iterrows():
        rows.append({"run": name, "effect": r.effect, "size": f"{r.width}x{r.height}", "triangles": r.triangles,
                     "build": r["params"].get("build"),
                     **{f"{k} ms": v for k, v in stages(r, ("gbuffer", "shadow", "peel", "count", "scan", "scatter",
                                                            "fill", "sort", "canon", "trace", "filter")).items()},
                     "total ms": r.total_ms, "peel layers": C(r, "peel_layers"), "fragments": C(r, "fragments"),
                     "LDI MB": (C(r, "ldi_bytes") or 0) / 2**20, "memory MB": r.memory_bytes / 2**20,
                     "crossings mean": C(r, "crossings_mean"), "PSNR": r.psnr, "SSIM": r.ssim, "FLIP": r.flip,
                     "relMSE": r.relmse, "status": r.status})
        img = (r["images"] or {}) if isinstance(r["images"], dict) else {}
        for k in ("image", "reference", "error"):
            src = work / name / str(img.get(k, ""))
            if img.get(k) and src.is_file() and src.stat().st_size < 600_000:
                shutil.copy(src, out / f"{name}-{k}.png")
if rows:
    tab = pd.DataFrame(rows)
    tab.to_csv(out / "indirect.csv", index=False)
    lines += ["## Image effects (150 LDIs of 128², rebuilt every frame; indirect: 8 rays/pixel + 11×11 Gaussian; "
              "glossy and soft shadows: 16 rays/pixel)", "", md(tab), ""]
text = "\n".join([f"# niessner2010 / ldi on {dev} (scale {scale})", ""] + lines)
(out / "summary.md").write_text(text)
print(text)
EOF
cat "$O/summary.md" 2>/dev/null || echo "no summary (see $O/log.txt)"
rm -rf "$W"
