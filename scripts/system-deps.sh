#!/usr/bin/env bash
# Debian system libraries ldbench needs: headless EGL + Mesa (llvmpipe) for moderngl, and LLVM 19 for
# Mitsuba's llvm_* variants (Debian 12's default LLVM 15 crashes them). Installs them when we are root;
# otherwise prints the exact command and fails.
set -euo pipefail
need=()
ls /usr/lib/*-linux-gnu/libLLVM-19.so* >/dev/null 2>&1 || ls /usr/lib/llvm-19/lib/libLLVM*.so* >/dev/null 2>&1 || need+=(libllvm19)
ls /usr/lib/*-linux-gnu/libEGL.so.1 >/dev/null 2>&1 || need+=(libegl1)
ls /usr/lib/*-linux-gnu/libEGL_mesa.so.0 >/dev/null 2>&1 || need+=(libegl-mesa0)
ls /usr/lib/*-linux-gnu/dri/swrast_dri.so >/dev/null 2>&1 || need+=(libgl1-mesa-dri)
[ ${#need[@]} -eq 0 ] && exit 0
if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
  echo "installing Debian packages: ${need[*]}"
  apt-get update -qq >/dev/null
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${need[@]}" >/dev/null
else
  echo "ldbench needs Debian packages: ${need[*]}; run: sudo apt-get install -y ${need[*]}" >&2
  exit 1
fi
