"""Rewrite the generated part of docs/reference/claims.md (between its claims:begin / claims:end markers) from the
reproduction registry: `python scripts/claims_md.py` after adding or changing a claim;
tests/test_reproduce_claims.py checks that the page is in step."""
from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ldbench.reports.reproduce import CLAIMS_BEGIN, CLAIMS_END, claims_markdown  # noqa: E402

page = ROOT / "docs" / "reference" / "claims.md"
text = page.read_text(encoding="utf-8")
head, rest = text.split(CLAIMS_BEGIN, 1)
_, tail = rest.split(CLAIMS_END, 1)
new = f"{head}{CLAIMS_BEGIN}\n\n{claims_markdown()}\n{CLAIMS_END}{tail}"
fd, tmp = tempfile.mkstemp(dir=page.parent, prefix=".claims.", suffix=".md")
with os.fdopen(fd, "w", encoding="utf-8") as f:
    f.write(new)
os.replace(tmp, page)
print(f"wrote {page.relative_to(ROOT)}")
