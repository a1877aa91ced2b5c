#!/usr/bin/env bash
# Debian system libraries ldbench needs: headless EGL + Mesa (llvmpipe) for moderngl, and a shared
# libLLVM >= 17 for Mitsuba's llvm_* variants (Debian 12's default LLVM 15 crashes them; any libLLVM
# >= 17 that ldbench/references/variant.py finds will do, else Debian's libllvm19 is installed). Installs them
# when we are root; otherwise prints the exact command and fails.
set -euo pipefail
MIN_LLVM=17

# Major version of the newest shared libLLVM in the places ldbench/references/variant.py searches (0: none).
newest_llvm() {
  local best=0 f v
  if [ -n "${DRJIT_LIBLLVM_PATH:-}" ] && [ -f "$DRJIT_LIBLLVM_PATH" ]; then set -- "$DRJIT_LIBLLVM_PATH"; else
    set -- /usr/lib/*-linux-gnu/libLLVM-*.so* /usr/lib/*-linux-gnu/libLLVM.so.* /usr/lib/llvm-*/lib/libLLVM*.so* \
           /usr/lib64/libLLVM*.so* /usr/lib/libLLVM*.so* /usr/local/lib/libLLVM*.so*
  fi
  for f in "$@"; do
    [ -f "$f" ] || continue
    v=$(printf '%s\n%s\n' "$f" "$(readlink -f "$f")" | sed -nE \
          's#.*libLLVM-([0-9]+).*#\1#p; t; s#.*libLLVM\.so\.([0-9]+).*#\1#p; t; s#.*llvm-([0-9]+)/.*#\1#p' | head -1)
    [ -n "$v" ] && [ "$v" -gt "$best" ] && best=$v
  done
  echo "$best"
}

need=()
[ "$(newest_llvm)" -ge "$MIN_LLVM" ] || need+=(libllvm19)
ls /usr/lib/*-linux-gnu/libEGL.so.1 >/dev/null 2>&1 || need+=(libegl1)
ls /usr/lib/*-linux-gnu/libEGL_mesa.so.0 >/dev/null 2>&1 || need+=(libegl-mesa0)
ls /usr/lib/*-linux-gnu/dri/swrast_dri.so >/dev/null 2>&1 || need+=(libgl1-mesa-dri)
# The tests of the report's image viewer run in a real browser: Chromium, installed where we may (root);
# elsewhere those tests skip and say so.
tests=()
command -v chromium >/dev/null || command -v chromium-browser >/dev/null || command -v google-chrome >/dev/null ||
  tests+=(chromium)
[ ${#need[@]} -eq 0 ] && [ ${#tests[@]} -eq 0 ] && exit 0
if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
  echo "installing Debian packages: ${need[*]} ${tests[*]}"
  apt-get update -qq >/dev/null
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${need[@]}" "${tests[@]}" >/dev/null
elif [ ${#need[@]} -gt 0 ]; then
  echo "ldbench needs Debian packages: ${need[*]}; run: sudo apt-get install -y ${need[*]}" >&2
  exit 1
else
  echo "note: the report viewer's browser tests need chromium (sudo apt-get install -y chromium); they skip" >&2
fi
