"""Choice of the Mitsuba 3 variant, and the libLLVM that Dr.Jit's LLVM backend needs.

``cuda_ad_rgb`` is used when a CUDA device works, else ``llvm_ad_rgb``. Mitsuba 3.9's LLVM variants
crash with LLVM 15 (Debian 12's default), so :func:`setup_llvm_env` points Dr.Jit at a libLLVM ≥ 17
through ``DRJIT_LIBLLVM_PATH`` before the LLVM backend starts. It must run before anything else in the
process uses the LLVM backend (Dr.Jit reads the variable once, when the backend initialises); importing
``mitsuba``/``drjit`` or using a ``scalar_*`` variant earlier is harmless.

Environment:

- ``LDBENCH_MITSUBA_VARIANT``: force ``cuda_ad_rgb`` or ``llvm_ad_rgb``.
- ``DRJIT_LIBLLVM_PATH``: respected when set (it must name an existing libLLVM ≥ 17 where the file
  name tells its version).
"""
from __future__ import annotations

import glob
import os
import re
import sys
from contextlib import contextmanager

from ldbench.core.errors import LdbenchError
from ldbench.core.signals import deferred_interrupt

# Lazy: drjit and mitsuba are imported by _choose() alone, under deferred_interrupt and after setup_llvm_env(), which
# must come before their first import; the other functions import them once a variant is chosen.

MIN_LLVM = 17
VARIANTS = ("cuda_ad_rgb", "llvm_ad_rgb")

_LLVM_PATTERNS = (
    "/usr/lib/*-linux-gnu/libLLVM-*.so*",
    "/usr/lib/*-linux-gnu/libLLVM.so.*",
    "/usr/lib/llvm-*/lib/libLLVM*.so*",
    "/usr/lib64/libLLVM*.so*",
    "/usr/lib/libLLVM*.so*",
    "/usr/local/lib/libLLVM*.so*",
    "/usr/local/opt/llvm/lib/libLLVM.dylib",
    "/opt/homebrew/opt/llvm/lib/libLLVM.dylib",
)

_chosen: str | None = None


def llvm_version_of(path: str) -> int | None:
    """Major LLVM version encoded in a library path (``libLLVM-19.so``, ``libLLVM.so.19.1``, ``llvm-19/``)."""
    name = os.path.basename(path)
    for pat in (r"libLLVM-(\d+)", r"libLLVM\.so\.(\d+)", r"libLLVM\.(\d+)\.dylib"):
        m = re.search(pat, name)
        if m:
            return int(m.group(1))
    m = re.search(r"llvm[-@]?(\d+)", path)
    return int(m.group(1)) if m else None


def find_libllvm() -> list:
    """Shared libLLVM candidates on this machine as (major version or None, path), best first."""
    seen, found = set(), []
    for pat in _LLVM_PATTERNS:
        for p in sorted(glob.glob(pat)):
            if p.endswith(".a") or not os.path.isfile(p):
                continue
            real = os.path.realpath(p)
            if real in seen:
                continue
            seen.add(real)
            found.append((llvm_version_of(p) or llvm_version_of(real), p))
    # Highest known version first; among equals prefer the unversioned-suffix name (libLLVM-19.so).
    found.sort(key=lambda vp: (-(vp[0] or 0), len(vp[1])))
    return found


def setup_llvm_env() -> str:
    """Make sure ``DRJIT_LIBLLVM_PATH`` names a libLLVM ≥ 17; return it. Raise LdbenchError if none exists."""
    cur = os.environ.get("DRJIT_LIBLLVM_PATH")
    if cur:
        if not os.path.isfile(cur):
            raise LdbenchError(f"DRJIT_LIBLLVM_PATH={cur} does not exist")
        v = llvm_version_of(cur) or llvm_version_of(os.path.realpath(cur))
        if v is not None and v < MIN_LLVM:
            raise LdbenchError(f"DRJIT_LIBLLVM_PATH={cur} is LLVM {v}; Mitsuba's LLVM backend needs "
                               f"libLLVM ≥ {MIN_LLVM}: apt-get install libllvm19")
        return cur
    cands = find_libllvm()
    good = [p for v, p in cands if v is not None and v >= MIN_LLVM]
    if not good:
        have = ", ".join(sorted({str(v) for v, _ in cands if v is not None})) or "none"
        raise LdbenchError(f"Mitsuba's LLVM backend needs libLLVM ≥ {MIN_LLVM} (found: {have}): "
                           f"apt-get install libllvm19, or set DRJIT_LIBLLVM_PATH")
    os.environ["DRJIT_LIBLLVM_PATH"] = good[0]
    return good[0]


def _try_variant(mi, dr, variant: str) -> bool:
    try:
        mi.set_variant(variant)
        x = dr.arange(mi.Float, 4) + 1
        return float(x.numpy().sum()) == 10.0
    except Exception:
        return False


def choose_variant() -> str:
    """``'cuda_ad_rgb'`` when a CUDA device works, else ``'llvm_ad_rgb'`` (libLLVM set up first).

    The choice is made once per process. Raises :class:`LdbenchError` (one line) when neither works.
    """
    if _chosen is not None:
        return _chosen
    forced = os.environ.get("LDBENCH_MITSUBA_VARIANT", "").strip()
    if forced and forced not in VARIANTS:
        raise LdbenchError(f"LDBENCH_MITSUBA_VARIANT={forced!r}: must be one of {', '.join(VARIANTS)}")

    with deferred_interrupt():  # a Ctrl-C inside Dr.Jit's start-up would fake "no usable variant" or abort
        return _choose(forced)


def _choose(forced: str) -> str:
    """:func:`choose_variant`'s search (``forced``: LDBENCH_MITSUBA_VARIANT), with Ctrl-C held back."""
    global _chosen
    llvm_err = None
    try:
        setup_llvm_env()  # before drjit/mitsuba can start the LLVM backend
    except LdbenchError as e:
        llvm_err = e
    try:
        import drjit as dr
        import mitsuba as mi
    except ImportError as e:
        raise LdbenchError(f"Mitsuba 3 is not installed ({e}): pip install 'mitsuba>=3.5'")
    available = set(mi.variants())

    order = [forced] if forced else list(VARIANTS)
    for v in order:
        if v not in available:
            continue
        if v.startswith("cuda"):
            try:
                if not dr.has_backend(dr.JitBackend.CUDA):
                    continue
            except Exception:
                continue
        else:
            if llvm_err is not None:
                continue
            try:
                if not dr.has_backend(dr.JitBackend.LLVM):
                    continue
            except Exception:
                continue
        if _try_variant(mi, dr, v):
            _chosen = v
            return v
    if forced:
        raise LdbenchError(f"Mitsuba variant {forced} (LDBENCH_MITSUBA_VARIANT) does not work here"
                           + (f": {llvm_err}" if llvm_err and forced.startswith("llvm") else ""))
    if llvm_err is not None:
        raise llvm_err
    raise LdbenchError(f"no usable Mitsuba variant among {', '.join(VARIANTS)} "
                       f"(this build has: {', '.join(sorted(available))})")


def mitsuba_version() -> str:
    import mitsuba as mi

    return str(mi.__version__)


if __name__ == "__main__":  # pragma: no cover
    try:
        print(choose_variant(), os.environ.get("DRJIT_LIBLLVM_PATH", ""))
    except LdbenchError as e:
        print(f"ldbench: error: {e}", file=sys.stderr)
        sys.exit(2)


@contextmanager
def variant_active(variant: str):
    """Mitsuba with ``variant`` set for the block; the caller's variant restored afterwards. On the CUDA
    variant, Dr.Jit's cache of freed device memory is handed back to the driver after the block: the OpenGL
    methods rendered next share that GPU, and the cache would otherwise keep the peak of every reference
    render (an OpenGL allocation that fails leaves a buffer of undefined contents)."""
    import mitsuba as mi

    prev = mi.variant()
    mi.set_variant(variant)
    try:
        yield mi
    finally:
        if variant.startswith("cuda"):
            try:
                import drjit as dr

                dr.sync_thread()
                dr.flush_malloc_cache()
            except Exception:  # a failing flush must not mask the block's own error
                pass
        if prev is not None and prev != variant:
            try:
                mi.set_variant(prev)
            except Exception:
                pass
