#!/usr/bin/env bash
# GPU measurements of LDM single-bounce indirect light (aalund2015 §4.2, Figure 10), on an NVIDIA
# GPU, run from the project root with the Python environment set up (about 3 minutes on an H200).
#   bash scripts/gpu/ldm-indirect-stages.sh                     outputs (CSV, Markdown, PNG; < 5 MB) under
#                                                               $OUT/ldm-indirect-stages
#   LDBENCH_GPU_DRY=1 bash scripts/gpu/ldm-indirect-stages.sh   every step at tiny sizes (llvmpipe: ~2 minutes)
# Steps: 1. the indirect-light tests on the GPU (real concurrency: photon counts, invariants); 2. stage times
# (light_raster, trace, splat), memory and counters at 800² on atrium (260k triangles) and cornell, blend
# and atomic splats; 3. `ldbench reproduce aalund2015-fig10`; 4. summary.md: the tables, the verdict of
# "splatting is the bottleneck, tracing is cheap" from the stage times and the blur proxy.
set -u
O="${OUT:-/tmp/ldbench-gpu}/ldm-indirect-stages"
W="${LDBENCH_GPU_WORK:-/tmp/ldbench-ldm-indirect-stages}"   # full run folders (EXR images) stay out of $OUT
mkdir -p "$O" "$W"
export LDBENCH_CACHE=${LDBENCH_CACHE:-/tmp/ldb-cache}
PY=${PY:-python3}
LD="$PY -m ldbench.harness.cli"
if [ "${LDBENCH_GPU_DRY:-0}" = 1 ]; then
    SIZE=32x32 TRI=4000 D=16 RES=32 R_ATR=16 R_COR=24 SPP=16 WARM=0 FRAMES=2 SCALE=ci TESTS=3
else
    SIZE=800x800 TRI=260000 D=512 RES=200 R_ATR=100 R_COR=128 SPP=256 WARM=2 FRAMES=5 SCALE=paper TESTS=240
fi
step() {  # step SECONDS NAME CMD...: run with a time limit, log, continue on failure
    local t=$1 name=$2; shift 2
    echo "== $name: $*" | tee -a "$O/log.txt"
    local t0=$SECONDS
    timeout "$t" "$@" > "$O/$name.log" 2>&1
    echo "   rc=$? in $((SECONDS - t0)) s" | tee -a "$O/log.txt"
}
nvidia-smi --query-gpu=name,driver_version,clocks.sm,memory.total --format=csv > "$O/gpu.txt" 2>&1
step 60 probe $PY -c "from ldbench.core.gpu import Gpu; g = Gpu(); print(g.info, g.device); \
print('GL_NV_shader_atomic_float', 'GL_NV_shader_atomic_float' in g.ctx.extensions); \
print('SSBO limit MiB', int(g.ctx.info['GL_MAX_SHADER_STORAGE_BLOCK_SIZE']) / 2**20)"

# 1. correctness on the GPU (skipped in the dry run: it is the CI suite there)
if [ "${LDBENCH_GPU_DRY:-0}" != 1 ]; then
    step "$TESTS" pytest $PY -m pytest -q -p no:cacheprovider tests/test_ldm_indirect.py
fi

# 2. stage times, memory, counters at $SIZE: atrium (Fig. 10's maps, R = 100, footprint 1) and cornell
#    (the adapter's defaults but 512 maps of 200²), blend and atomic splats
cat > "$W/stages.toml" <<EOF
[suite]
name = "ldm-indirect-stages"
size = "$SIZE"
spp = $SPP
warmup = $WARM
frames = $FRAMES

[[run]]
scene = "atrium"
scene_params = { triangles = $TRI }
effect = "indirect"
methods = ["ldm"]

[run.params.ldm]
directions = $D
resolution = $RES
photons = $R_ATR
footprint_scale = 1.0
splat = ["blend", "atomic"]

[[run]]
scene = "cornell"
effect = "indirect"
methods = ["ldm"]

[run.params.ldm]
directions = $D
resolution = $RES
photons = $R_COR
splat = ["blend", "atomic"]
EOF
step 150 stages $LD run "$W/stages.toml" --out "$W/stages" --no-progress --no-report

# 3. Figure 10
step 200 fig10 $LD reproduce aalund2015-fig10 --scale "$SCALE" --out "$W/fig10" --no-progress --no-report
cp "$W/fig10/reproduce.md" "$O/fig10-reproduce.md" 2>/dev/null

# 4. tables, verdicts, a comparison strip
step 120 summary $PY - "$W" "$O" <<'EOF'
import json, sys
from pathlib import Path

import numpy as np
import pandas as pd

work, out = Path(sys.argv[1]), Path(sys.argv[2])
STAGES = ("gbuffer", "build", "light_raster", "trace", "splat")


def load(run):
    p = work / run / "results.csv"
    if not p.exists():
        return None
    df = pd.read_csv(p)
    df.to_csv(out / f"{run}-results.csv", index=False)
    return df


def js(v):
    return json.loads(v) if isinstance(v, str) and v else {}


def rgb(path):
    from ldbench.core.exr import read_exr

    ch = read_exr(path)
    return np.stack([ch[c] for c in "RGB"], -1) if "R" in ch else ch["Y"][..., None]


def blur_proxy(run_dir, row):
    """Edge energy of the method relative to the reference: Σ|∇L| / Σ|∇L_ref| of the luminance after 4×4
    box averaging (which removes most of the reference's Monte Carlo noise), over blocks the camera fully
    covers. Below 1: smoother than the reference (blurred indirect shadows); banding pushes it up."""
    im = js(row["images"])
    if not im.get("exr") or im["exr"] in SHARED:  # two jobs whose truncated labels share one image file
        return float("nan")
    ref_png = im.get("reference", "")
    m, r = rgb(run_dir / im["exr"]), rgb(run_dir / ref_png.replace(".png", ".exr"))
    lum = lambda a: a[..., :3].mean(-1)
    h, w = (m.shape[0] // 4) * 4, (m.shape[1] // 4) * 4
    box = lambda a: a[:h, :w].reshape(h // 4, 4, w // 4, 4).mean((1, 3))
    cover = box((lum(r) > 0).astype(float)) == 1.0
    def energy(a):
        b = box(lum(a))
        gx, gy = np.zeros_like(b), np.zeros_like(b)
        gx[:, :-1], gy[:-1] = np.abs(np.diff(b, axis=1)), np.abs(np.diff(b, axis=0))
        ok = cover & np.roll(cover, -1, 1) & np.roll(cover, -1, 0)
        return float((gx + gy)[ok].sum())
    e = energy(r)
    return energy(m) / e if e > 0 else float("nan")


lines = ["# LDM indirect light on the GPU (aalund2015 §4.2, Fig. 10)", ""]
for run in ("stages", "fig10"):
    df = load(run)
    if df is None:
        lines += [f"{run}: no results", ""]
        continue
    exrs = [js(v).get("exr") for v in df["images"]]
    SHARED = {e for e in exrs if e and exrs.count(e) > 1}
    head = ["scene", "effect", "params", *STAGES, "total ms", "memory MB (LDMs, photons)", "stored photons",
            "splat px", "clipped", "PSNR", "SSIM", "blur proxy", "splat is the bottleneck"]
    lines += [f"## {run}", "", f"device: {df['device'].iloc[0]}, {df['gl_renderer'].iloc[0]}", "",
              "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for _, r in df.iterrows():
        if r["status"] != "ok" and not str(r["status"]).startswith("degraded"):
            lines.append(f"| {r['scene']} | {r['effect']} | {r['params']} | {r['status']} |")
            continue
        st, c, p, mem = js(r["stage_ms"]), js(r["counters"]), js(r["params"]), js(r["memory"])
        names = ("directions", "resolution") + (("photons", "footprint_scale", "rotation", "splat")
                                                if r["effect"] == "indirect" else ())
        keep = {k: p[k] for k in names if k in p}
        ldm = sum(v for k, v in mem.items() if "ldm." in k) / 2**20
        pho = sum(v for k, v in mem.items() if "photons." in k) / 2**20
        if r["effect"] == "indirect":
            sp, tr = st.get("splat", 0.0), st.get("trace", 0.0) + st.get("light_raster", 0.0)
            verdict = ("holds" if sp > 0.5 * r["total_ms"] else "does not hold") + \
                      f" (splat {sp / r['total_ms']:.0%} of the frame, {sp / max(tr, 1e-9):.1f}× trace + light raster)"
            blur = blur_proxy(work / run, r)
        else:
            verdict, blur = "–", float("nan")
        lines.append(f"| {r['scene']} | {r['effect']} | {keep} | "
                     + " | ".join(f"{st[s]:.1f}" if s in st else "–" for s in STAGES)
                     + f" | {r['total_ms']:.1f} | {r['memory_bytes'] / 2**20:.1f} ({ldm:.1f}, {pho:.1f}) | "
                     f"{c.get('photons_stored', '–')} | {c.get('splat_pixels', float('nan')):.3g} | "
                     f"{c.get('splats_clipped', '–')} | {r['psnr']:.2f} | {r['ssim']:.3f} | {blur:.3f} | {verdict} |")
    lines.append("")
lines += ["blur proxy: Σ|∇L| / Σ|∇L_ref| of the luminance after 4×4 box averaging (below 1: smoother than the "
          "reference; nan where two jobs' truncated image names collide); 'splat is the bottleneck' holds when "
          "the splat stage takes a majority (more than half) of the frame, aalund2015 §5.2's words and the rule "
          "of `ldbench reproduce aalund2015-fig10` (GPU timer queries)."]
(out / "summary.md").write_text("\n".join(lines) + "\n")
print("\n".join(lines))

# a strip: Fig. 10's blend rows by footprint and R, then the reference (downscaled)
try:
    import matplotlib.image as mpimg
    df = pd.read_csv(work / "fig10" / "results.csv")
    rows = [(js(r["params"]), js(r["images"])) for _, r in df[df["effect"] == "indirect"].iterrows()]
    exrs = [im.get("exr") for _, im in rows]
    rows = [(p, im) for p, im in rows if exrs.count(im.get("exr")) == 1]  # not a shared (overwritten) file
    rows = sorted((p["footprint_scale"], p["photons"], p.get("rotation", "incident"), im) for p, im in rows
                  if p.get("splat", "blend") == "blend" and im.get("image"))
    tiles = [mpimg.imread(work / "fig10" / im["image"])[..., :3] for *_, im in rows]
    names = [f"footprint {fs:g}, R = {r}, {rot}" for fs, r, rot, _ in rows]
    if rows:
        tiles.append(mpimg.imread(work / "fig10" / rows[0][-1]["reference"])[..., :3])
        names.append("reference")
        step = max(1, tiles[0].shape[0] // 300)
        strip = np.concatenate([t[::step, ::step] for t in tiles], 1)
        mpimg.imsave(out / "fig10-strip.png", np.clip(strip, 0, 1))
        (out / "fig10-strip.txt").write_text("left to right: " + ", ".join(names) + "\n")
except Exception as e:  # noqa: BLE001 - the tables above are what matters
    print("strip:", e)
EOF
ls -la "$O" >> "$O/log.txt"
