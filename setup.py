"""Build hook only (the project is described in pyproject.toml): a wheel records the commit it was built
from in ``ldbench/core/build_info.json``, so an installed ldbench still knows its commit (ldbench/core/plugins.py,
``ldbench_info``). Outside a git checkout the file holds ``LDBENCH_COMMIT`` / ``LDBENCH_DIRTY`` if set,
else nulls."""
import json
import os
import subprocess
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

HERE = Path(__file__).resolve().parent


def _git(*args):
    try:
        p = subprocess.run(["git", "-C", str(HERE), *args], capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return None
    return p.stdout.strip() if p.returncode == 0 else None


def build_info() -> dict:
    top = _git("rev-parse", "--show-toplevel")
    if top and os.path.samefile(top, HERE):
        status = _git("status", "--porcelain", "--untracked-files=no")
        return {"commit": _git("rev-parse", "--verify", "-q", "HEAD") or None,
                "dirty": None if status is None else bool(status)}
    dirty = os.environ.get("LDBENCH_DIRTY")
    return {"commit": os.environ.get("LDBENCH_COMMIT") or None, "dirty": None if dirty is None else dirty == "1"}


class BuildPyWithInfo(build_py):
    def run(self):
        super().run()
        target = Path(self.build_lib) / "ldbench" / "core" / "build_info.json"
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(json.dumps(build_info()) + "\n")


setup(cmdclass={"build_py": BuildPyWithInfo})
