#!/usr/bin/env bash
# Run several of the GPU scripts in scripts/gpu/ back to back, each capped in time, and pack every output
# into ONE archive ($OUT/gpu-NAME.tgz: one file to copy back from the GPU machine).
#   bash scripts/gpu/batch.sh NAME MIRROR SCRIPT:SECONDS ...   e.g. batch.sh a /tmp/mirror ldm-rays:150 fast-builds:240
# SCRIPT: a script's name without .sh (ldm-rays, ldi-build-trace, cdi-vpl-tables, ldm-indirect-stages,
# oit-table1-sweep, fast-builds, ray-executor-speedup). MIRROR: a scene mirror (`ldbench scenes fetch --from`)
# holding sponza/, sibenik/ and stanford_dragon/, passed to the scripts that use it.
set -u
name=$1 mirror=$2; shift 2
final="${OUT:-/tmp/ldbench-gpu}"
export OUT="/tmp/gpu-$name"
rm -rf "$OUT"; mkdir -p "$OUT"
export PYTHON=${PYTHON:-python3}
for spec in "$@"; do
    s=${spec%%:*} cap=${spec##*:}
    t0=$SECONDS
    case $s in
        ldm-rays|ldi-build-trace|oit-table1-sweep) args=("$mirror") ;;
        *) args=() ;;
    esac
    echo "==== $s (cap $cap s)" | tee -a "$OUT/batch.log"
    timeout --kill-after=10 "$cap" bash "scripts/gpu/$s.sh" "${args[@]}" > "$OUT/$s.stdout" 2>&1
    echo "     rc=$? in $((SECONDS - t0)) s" | tee -a "$OUT/batch.log"
done
mkdir -p "$final"
tar czf "$final/gpu-$name.tgz" -C /tmp "gpu-$name"
ls -la "$final"
