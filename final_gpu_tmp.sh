#!/usr/bin/env bash
set -u
export LDBENCH_CACHE=/tmp/ldb-cache LDBENCH_SCENES=/tmp/ldb-scenes
W=/tmp/wA; mkdir -p $W
s0=$SECONDS
timeout 60 python3 scripts/gpu/gbuffer_bench.py --max-pixels 64,256,1024 > $W/gbuffer.txt 2>&1; tail -8 $W/gbuffer.txt
python3 scripts/gpu/fast_builds_bench.py $W bandwidth > /dev/null 2>&1
timeout 170 python3 scripts/gpu/fast_defaults.py $W > $W/fd.log 2>&1; tail -18 $W/fd.log | cut -c1-400
echo "t=$((SECONDS-s0))"
timeout 80 python3 scripts/gpu/fast_builds_bench.py $W triangles --variants splat/linked-yang > $W/tri.log 2>&1
timeout 50 python3 scripts/gpu/fast_builds_bench.py $W maps --variants splat/linked-yang > $W/maps.log 2>&1
grep -o "triangles=[0-9]* maps=[0-9]* .*build_ms=[^ ]*" $W/tri.log $W/maps.log | cut -c1-120
echo "t=$((SECONDS-s0))"
tar czf $OUT/perf.tgz --exclude='*.exr' --exclude='*.npz' --exclude='*.png' -C $W .
left=$((540 - (SECONDS - s0)))
echo "left for reproductions: $left s"
[ $left -gt 60 ] && OUT=$OUT bash scripts/gpu/reproduce-verdicts.sh .gpu-scenes $((left / 4)) aalund2015-trace yang2010-costs aalund2015-fig8-real archer2019-table1
cat /tmp/ldbench-gpu/reproduce-verdicts/log.txt 2>/dev/null
ls -la $OUT
