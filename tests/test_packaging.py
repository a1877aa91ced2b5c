"""ldbench as an installed package: build the wheel, install it into a fresh venv, run it elsewhere.

The venv reuses this environment's dependencies through a .pth line (no network), but not its ldbench:
a .pth line adds a directory without running the .pth files in it, so the editable install of the
checkout stays invisible and only the wheel's copy can be imported.
"""
import json
import os
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

from ldbench.harness import records
from layout import PACKAGE, ROOT, import_prefix, installed_path, packages

PACKAGES = tuple(packages())
PREFIX = import_prefix()  # "ldbench." once the folders are installed under one name
ADAPTER_DIRS = sorted(p.parent.name for p in (PACKAGE / "methods").glob("*/__init__.py"))
TINY = ["--size", "16x16", "--spp", "1", "--frames", "1", "--warmup", "0", "--no-report", "--no-progress"]


def _git(cwd, *args):
    return subprocess.run(["git", "-C", str(cwd), *args], check=True, capture_output=True, text=True).stdout


def _git_repo(path: Path) -> str:
    """A repository at ``path`` with one commit; returns the commit."""
    path.mkdir(parents=True, exist_ok=True)
    _git(path, "init", "-q")
    _git(path, "-c", "user.email=t@example.com", "-c", "user.name=t", "commit", "-q", "--allow-empty", "-m", "x")
    return _git(path, "rev-parse", "HEAD").strip()


def _expected_files() -> set:
    """What the wheel must hold: every module, adapter, GLSL file, registry and bundled suite."""
    out = set()
    for pkg in PACKAGES:
        for p in (PACKAGE / pkg).rglob("*"):
            if p.is_file() and "__pycache__" not in p.parts and p.suffix in (".py", ".glsl", ".toml", ".js", ".css"):
                out.add(installed_path(p.relative_to(PACKAGE).as_posix()))
    out |= {installed_path(f"harness/suites/{p.name}") for p in (ROOT / "suites").glob("*.toml")}
    return out


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """(venv python, work dir, env): the wheel built from a copy of the tree, installed into a venv
    that lives inside an unrelated git repository."""
    tmp = tmp_path_factory.mktemp("pkg")
    src = tmp / "src"
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info", "build")
    src.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, src / name)
    for name in ("ldbench", "suites"):
        shutil.copytree(ROOT / name, src / name, symlinks=True, ignore=ignore)
    dist = tmp / "dist"
    p = subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation",
                        "--no-index", "-w", str(dist), str(src)], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, f"wheel build failed (pip install -e '.[test]' provides 'wheel'):\n{p.stderr[-3000:]}"
    (wheel,) = dist.glob("ldbench-*.whl")

    other_repo = tmp / "someone-elses-repo"
    other_commit = _git_repo(other_repo)
    venv = other_repo / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True, timeout=120)
    py = venv / "bin" / "python"
    purelib = Path(subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
                                  check=True, capture_output=True, text=True).stdout.strip())
    deps = {sysconfig.get_path("purelib"), sysconfig.get_path("platlib")}
    deps |= {p for p in sys.path if p.endswith(("site-packages", "dist-packages")) and Path(p).is_dir()}  # .pth-added
    (purelib / "ldbench-test-deps.pth").write_text("".join(f"{d}\n" for d in sorted(deps)))
    p = subprocess.run([sys.executable, "-m", "pip", "--python", str(py), "install", "-q", "--no-deps", "--no-index",
                        str(wheel)], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr[-3000:]

    work = tmp / "work"
    work.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "LDBENCH_COMMIT", "LDBENCH_DIRTY")}
    env.update(LDBENCH_CACHE=str(tmp / "ref-cache"), LDBENCH_SCENES=str(tmp / "scenes"), PYTHONNOUSERSITE="1")
    return {"py": py, "ldbench": venv / "bin" / "ldbench", "work": work, "env": env, "wheel": wheel,
            "purelib": purelib, "other_commit": other_commit}


def _run(inst, *args, timeout=300):
    p = subprocess.run([str(a) for a in args], cwd=inst["work"], env=inst["env"], capture_output=True, text=True,
                       timeout=timeout)
    assert p.returncode == 0, f"{' '.join(map(str, args))} -> {p.returncode}\n{p.stdout[-2000:]}\n{p.stderr[-3000:]}"
    return p.stdout


def test_wheel_holds_every_adapter_glsl_and_suite(installed):
    names = set(zipfile.ZipFile(installed["wheel"]).namelist())
    missing = _expected_files() - names
    assert not missing, f"missing from the wheel: {sorted(missing)}"
    assert len(ADAPTER_DIRS) >= 3
    for a in ADAPTER_DIRS:
        assert installed_path(f"methods/{a}/__init__.py") in names
    registry_toml = next(PACKAGE.glob("*/scene_registry.toml")).relative_to(PACKAGE).as_posix()
    assert installed_path(registry_toml) in names and installed_path("harness/suites/default.toml") in names
    # a paper table's suite rides in its own folder, beside the entry (ldbench/reports/reproductions/<paper>/<table>/)
    assert installed_path("reports/reproductions/aalund2015/fig8/suite.toml") in names
    top = {n.split("/")[0] for n in names} - {n.split("/")[0] for n in names if ".dist-info/" in n}
    # nothing generic at the top of site-packages: one import name once the folders are mapped under it
    assert top == ({PREFIX[:-1]} if PREFIX else set(PACKAGES)), sorted(top)


def test_installed_ldbench_runs_outside_the_source_tree(installed):
    where = _run(installed, installed["py"], "-c", f"import importlib; print(*(importlib.import_module('{PREFIX}' + p)"
                 f".__file__ for p in {PACKAGES!r}))")
    assert all(Path(p).is_relative_to(installed["purelib"]) for p in where.split()), where
    from ldbench.methods.base import registry

    out = _run(installed, installed["ldbench"], "methods")
    listed = {line.split()[0] for line in out.splitlines() if line and not line[0].isspace()}
    assert listed == set(registry()) and len(listed) >= 3, out  # every adapter of the checkout
    assert "sponza" in _run(installed, installed["ldbench"], "scenes")  # the registry is package data
    table = _run(installed, installed["py"], "-c", "from ldbench.harness.resources import suite_path; "
                 "print(suite_path('suites/aalund2015-fig8.toml'))").strip()  # a paper table's suite by its key
    assert Path(table).is_file() and Path(table).is_relative_to(installed["purelib"]), table

    _run(installed, installed["ldbench"], "run", "--scene", "cornell", "--method", "direct-raster", "--effect",
         "direct", "--out", "r", *TINY)
    assert (installed["work"] / "r" / "results.parquet").is_file()
    # ldbench sits inside someone else's repository: their commit is not ldbench's
    rows = _run(installed, installed["py"], "-c", "import pandas, json; d = pandas.read_parquet('r/results.parquet');"
                "print(json.dumps(d[['commit', 'status']].to_dict('records')))")
    assert json.loads(rows) == [{"commit": None, "status": "ok"}]


@pytest.mark.slow  # a whole run from the installed wheel (~10 s on two cores)
def test_bundled_suite_by_name(installed):
    path = _run(installed, installed["py"], "-c", "from ldbench.harness.resources import suite_path; print(suite_path('default'))")
    path = Path(path.strip())
    assert path.is_file() and path.is_relative_to(installed["purelib"]), path
    assert _run(installed, installed["py"], "-c", "from ldbench.harness.resources import suite_path; "
                "print(suite_path('suites/default.toml'))").strip() == str(path)
    _run(installed, installed["ldbench"], "run", path, "--out", "s", *TINY)
    assert (installed["work"] / "s" / "results.parquet").is_file()


# --------------------------------------------------------------------------------------------------
# commit detection (ldbench/harness/records.py)


@pytest.mark.skipif(shutil.which("git") is None, reason="git not installed")
def test_commit_only_from_ldbench_own_repository(tmp_path, monkeypatch):
    monkeypatch.delenv("LDBENCH_COMMIT", raising=False)
    monkeypatch.delenv("LDBENCH_DIRTY", raising=False)
    commit = _git_repo(tmp_path / "outer")
    inner = tmp_path / "outer" / "vendor" / "ldbench"  # ldbench copied into another project
    inner.mkdir(parents=True)
    assert records.git_info(tmp_path / "outer")["commit"] == commit  # its own root: accepted
    assert records.git_info(inner) == {"commit": None, "dirty": None, "branch": None}
    monkeypatch.setenv("LDBENCH_COMMIT", "abc123")
    monkeypatch.setenv("LDBENCH_DIRTY", "1")
    assert records.git_info(inner) == {"commit": "abc123", "dirty": True, "branch": None}
    # named, it wins over a repository's own .git too (a copied tree whose .git is stale)
    assert records.git_info(tmp_path / "outer") == {"commit": "abc123", "dirty": True, "branch": None}
    # the default root is ldbench's own folder
    assert records.LDBENCH_ROOT == ROOT


@pytest.mark.skipif(not (ROOT / ".git").exists(), reason="not a git checkout")
def test_checkout_records_its_own_commit(monkeypatch):
    monkeypatch.delenv("LDBENCH_COMMIT", raising=False)
    assert records.git_info()["commit"] == _git(ROOT, "rev-parse", "HEAD").strip()
