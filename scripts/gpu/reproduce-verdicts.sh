#!/usr/bin/env bash
# Paper reproductions at paper scale on a GPU, and suites beside them, packed for the trip back.
#
# Usage, from the project root with its Python environment set up:
#     OUT=/some/dir bash scripts/gpu/reproduce-verdicts.sh MIRROR SECONDS KEY_OR_SUITE ...
# KEY_OR_SUITE: a `ldbench reproduce` key (e.g. aalund2015-fig8) or a suite file (suites/*.toml);
# MIRROR: a scene mirror (`ldbench scenes fetch --from`) holding the real scenes they use (what it lacks is
# skipped with one line). Each step runs under `timeout SECONDS`. Outputs: per step its reproduce.md /
# summary.md, results.csv/parquet and log, packed into "$OUT/reproduce-verdicts.tgz.part-*" (15 MB pieces).
set -u
mirror=$1 cap=$2; shift 2
O="${OUT:-/tmp/ldbench-gpu}/reproduce-verdicts"
mkdir -p "$O"
export LDBENCH_CACHE=${LDBENCH_CACHE:-/tmp/ldb-cache} LDBENCH_SCENES=${LDBENCH_SCENES:-/tmp/ldb-scenes}
PY="${PYTHON:-python3}"
LD="$PY -m ldbench.harness.cli"
W="$(mktemp -d "${TMPDIR:-/tmp}/reproduce-verdicts.XXXXXX")"
nvidia-smi --query-gpu=name,driver_version --format=csv > "$O/gpu.txt" 2>&1
for s in sponza sibenik dragon; do $LD scenes fetch $s --from "$mirror" >> "$O/fetch.log" 2>&1; done
for k in "$@"; do
    n=$(basename "$k" .toml)
    t0=$SECONDS
    if [ -f "$k" ]; then
        timeout "$cap" $LD run "$k" --out "$W/$n" --no-progress > "$O/$n.log" 2>&1
    else
        timeout "$cap" $LD reproduce "$k" --out "$W/$n" --no-progress > "$O/$n.log" 2>&1
    fi
    echo "$n: rc=$? in $((SECONDS - t0)) s" | tee -a "$O/log.txt"
    mkdir -p "$O/$n"
    cp "$W/$n"/*.md "$W/$n"/results.* "$O/$n/" 2>/dev/null
done
tar czf "$W/pack.tgz" -C "$(dirname "$O")" "$(basename "$O")" && split -b 15m "$W/pack.tgz" "$O.tgz.part-" && rm -rf "$O"
