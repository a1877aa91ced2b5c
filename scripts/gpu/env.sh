# Source this (bash) in the project root to import ldbench from the checkout without installing it, e.g. on a
# GPU host with no build tools:   . scripts/gpu/env.sh
# The layers are the top-level folders of the checkout; installed, they are the sub-packages of `ldbench`
# (pyproject's package-dir). Here a folder of links under $LDBENCH_LINKS (default /tmp/ldbench-links) maps
# ldbench.<layer> to ./<layer>, and it goes first on PYTHONPATH.
_ldb_links="${LDBENCH_LINKS:-/tmp/ldbench-links}"
mkdir -p "$_ldb_links/ldbench"
for _ldb_d in core harness methods references reports; do ln -sfn "$PWD/$_ldb_d" "$_ldb_links/ldbench/$_ldb_d"; done
export PYTHONPATH="$_ldb_links${PYTHONPATH:+:$PYTHONPATH}"
unset _ldb_links _ldb_d
