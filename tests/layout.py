"""The source tree's packages and their installed import name, read from the tree (no package import), so
that the layering and packaging tests hold for the folders as they are: top-level ``harness``, ``methods``,
``references``, or the same folders installed under one name (``ldbench.harness`` <- ``harness/``, as
``pyproject.toml``'s ``[tool.setuptools.package-dir]`` maps them)."""
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def packages() -> list[str]:
    """The top-level folders of the tree that are Python packages (tests excluded)."""
    return sorted(p.parent.name for p in ROOT.glob("*/__init__.py") if p.parent.name != "tests")


def import_prefix() -> str:
    """``"ldbench."`` when pyproject maps the folders under one import name, else ``""``."""
    cfg = tomllib.loads((ROOT / "pyproject.toml").read_text())
    dirs = cfg.get("tool", {}).get("setuptools", {}).get("package-dir", {})
    names = {k.split(".")[0] for k in dirs if k}
    return f"{names.pop()}." if len(names) == 1 else ""


def installed_path(rel: str) -> str:
    """Where the tree's file ``rel`` (e.g. ``methods/ldm/__init__.py``) lies in the wheel."""
    return import_prefix().replace(".", "/") + rel
