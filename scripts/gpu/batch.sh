#!/usr/bin/env bash
# Run several issues' GPU scripts back to back on the lent GPU, each capped in time, and pack every output
# into ONE archive ($OUT/gpu-NAME.tgz: the device returns at most 8 files).
#   bash scripts/gpu/run_all.sh NAME MIRROR ISSUE:SECONDS ...     e.g. run_all.sh a /tmp/mirror 9:150 14:240
# MIRROR: a folder laid out like shared/scenes (sponza, sibenik, the dragon), passed to the scripts that use it.
set -u
name=$1 mirror=$2; shift 2
final="${OUT:-/tmp/ldbench-gpu}"
export OUT="/tmp/gpu-$name"
rm -rf "$OUT"; mkdir -p "$OUT"
export PYTHON=${PYTHON:-python3}
for spec in "$@"; do
    i=${spec%%:*} cap=${spec##*:}
    t0=$SECONDS
    case $i in
        9|10|13) args=("$mirror") ;;
        *) args=() ;;
    esac
    echo "==== issue $i (cap $cap s)" | tee -a "$OUT/run_all.log"
    timeout --kill-after=10 "$cap" bash "scripts/gpu/issue$i.sh" "${args[@]}" > "$OUT/issue$i.stdout" 2>&1
    echo "     rc=$? in $((SECONDS - t0)) s" | tee -a "$OUT/run_all.log"
done
mkdir -p "$final"
tar czf "$final/gpu-$name.tgz" -C /tmp "gpu-$name"
ls -la "$final"
