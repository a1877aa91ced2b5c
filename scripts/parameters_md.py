"""Write docs/reference/parameters.md, the parameter reference generated from the methods', effects' and
scenes' ``Params`` declarations: `python scripts/parameters_md.py` after adding or changing a parameter;
tests/test_paramdoc.py checks that the page is in step."""
from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ldbench.core.errors import LdbenchError  # noqa: E402
from ldbench.harness.reference_page import PAGE, write_page  # noqa: E402

try:
    write_page(ROOT / PAGE)
except LdbenchError as e:
    sys.exit(f"parameters_md: {e}")
print(f"wrote {PAGE}")
