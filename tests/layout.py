"""The source tree's layers, read from the tree (no package import), for the layering and packaging tests:
the sub-packages of the ``ldbench/`` folder (``core``, ``methods``, ``references``, ``harness``,
``reports``), installed under the import name ``ldbench``."""
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "ldbench"


def packages() -> list[str]:
    """The layers: the sub-packages of ``ldbench/``."""
    return sorted(p.parent.name for p in PACKAGE.glob("*/__init__.py"))


def import_prefix() -> str:
    """The import prefix of a layer's modules."""
    return "ldbench."


def installed_path(rel: str) -> str:
    """Where the package file ``rel`` (e.g. ``ldbench/methods/ldm/__init__.py``) lies in the wheel."""
    return "ldbench/" + rel
