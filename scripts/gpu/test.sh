#!/usr/bin/env bash
# Run the whole test suite on a GPU host, offline, and leave a JUnit XML and a one-line summary.
#
#   bash scripts/gpu/test.sh [SCENES] [PYTEST ARGS...]
#
# TESTS (default: tests, the whole suite, both tiers: LDBENCH_SLOW=1) narrows the run, e.g.
# TESTS=tests/test_concurrency.py; LDBENCH_SLOW=0 leaves out the tests marked slow.
# SCENES: a scene mirror (a folder holding scenes/), or a .tar.xz of that scenes/ folder; default
# $LDBENCH_SHARED. Without it the tests that need real scenes skip and say so in the summary.
#
# The host needs Python >= 3.11 with numpy, scipy, pandas, pyarrow, scikit-image, matplotlib, pytest (and
# pytest-xdist to run in parallel, pytest-timeout for a per-test limit), setuptools >= 77 and wheel. Offline,
# the wheels of .offline/wheels (an offline kit: moderngl, Mitsuba, Dr.Jit, ...) are installed first. The checkout
# is then installed in editable mode (`pip install -e .`, no network), so that the tests' subprocesses and
# the virtual environments they make import the same code as pytest.
#
# Writes under $OUT (default /tmp/ldbench-gpu-tests):
#   junit.xml      every test's outcome (pytest --junitxml)
#   pytest.log     pytest's output
#   summary.txt    one line: device, driver, counts, wall time
#   setup.log      what the installs printed
#   gpu-memory.csv the GPU's memory in use and load every 5 s (where nvidia-smi exists)
# Exit status: pytest's.
set -uo pipefail
cd "$(dirname "$0")/../.."
OUT=${OUT:-/tmp/ldbench-gpu-tests}
mkdir -p "$OUT"
PY=${PYTHON:-python3}

src=${1:-${LDBENCH_SHARED:-}}
[ $# -gt 0 ] && shift
if [ -f "$src" ]; then  # a tarball of scenes/: unpacked once per host
    dst=/tmp/ldbench-shared
    [ -d "$dst/scenes" ] || { mkdir -p "$dst" && tar -xJf "$src" -C "$dst"; }
    src=$dst
fi
if [ -n "$src" ] && [ -d "$src/scenes" ]; then export LDBENCH_SHARED=$(cd "$src" && pwd)
else echo "note: no scene mirror (SCENES or LDBENCH_SHARED); tests on real scenes skip" >&2; fi

# Offline, the kit's wheels go to a folder named site-packages that a .pth file of this Python names: then the
# tests' subprocesses (whatever PYTHONPATH they set) and the virtual environments they make (which list this
# Python's site-packages folders) find them too.
log="$OUT/setup.log"; : > "$log"
pipi() { $PY -m pip install -q --no-index --no-deps --disable-pip-version-check "$@" >>"$log" 2>&1; }
purelib=$($PY -c "import sysconfig; print(sysconfig.get_path('purelib'))")
if [ -d .offline/wheels ]; then
    deps=/tmp/ldbench-offline/site-packages
    pipi --no-compile --upgrade --target "$deps" .offline/wheels/*.whl || { echo "error: the offline wheels did not install: $log" >&2; exit 2; }
    echo "$deps" > "$purelib/ldbench-offline.pth" 2>>"$log" ||
        echo "warning: $purelib is read-only: tests whose subprocesses reset PYTHONPATH will not find the wheels" >&2
    export PYTHONPATH=$deps
else
    unset PYTHONPATH
fi
pipi --no-build-isolation -e . || { echo "error: pip install -e . failed (setuptools >= 77 and wheel?): $log" >&2; exit 2; }
$PY -c "import ldbench.core.gpu, moderngl, mitsuba, drjit" >>"$log" 2>&1 || { echo "error: imports fail: $log" >&2; exit 2; }

# One worker a core (at most 16), each with one thread for numpy's BLAS and Arrow: the workers share the
# cores, and every worker opens its own GL context on the one GPU.
jobs=${JOBS:-$(( $(nproc) > 16 ? 16 : $(nproc) ))}
export LDBENCH_SLOW=${LDBENCH_SLOW:-1}
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 ARROW_NUM_THREADS=1
extra=()
$PY -c "import xdist" 2>/dev/null && extra+=(-n "$jobs" --dist worksteal)
$PY -c "import pytest_timeout" 2>/dev/null && extra+=(--timeout "${TEST_TIMEOUT:-420}")
command -v nvidia-smi >/dev/null && { nvidia-smi --query-gpu=timestamp,memory.used,utilization.gpu --format=csv \
    -l 5 > "$OUT/gpu-memory.csv" 2>/dev/null & smi=$!; }
t0=$SECONDS
$PY -m pytest -q -p no:cacheprovider -rs --durations=40 "${extra[@]}" --junitxml="$OUT/junit.xml" ${TESTS:-tests} "$@" 2>&1 \
    | tee "$OUT/pytest.log"
rc=${PIPESTATUS[0]}
[ -n "${smi:-}" ] && kill "$smi" 2>/dev/null
wall=$((SECONDS - t0))
$PY - "$OUT" "$wall" <<'PY' | tee "$OUT/summary.txt"
import sys, datetime, xml.etree.ElementTree as ET
from ldbench.core.gpu import Gpu
out, wall = sys.argv[1], int(sys.argv[2])
r = ET.parse(f"{out}/junit.xml").getroot()
suites = [r] if r.tag == "testsuite" else list(r)
n = {k: sum(int(s.get(k, 0)) for s in suites) for k in ("tests", "failures", "errors", "skipped")}
passed = n["tests"] - n["failures"] - n["errors"] - n["skipped"]
g = Gpu()
dev, ver = g.ctx.info["GL_RENDERER"], g.ctx.info["GL_VERSION"]
g.release()
print(f"{datetime.date.today()} {dev} ({ver}): {passed} passed, {n['failures']} failed, {n['errors']} errors, "
      f"{n['skipped']} skipped in {wall} s")
PY
exit "$rc"
