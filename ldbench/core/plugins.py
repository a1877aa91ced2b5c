"""Methods, effects and scenes from outside ldbench: entry points, ``package.module:Class`` references, provenance.

=======================  ===========================================================================
entry points             an installed distribution declares ``[project.entry-points."ldbench.methods"]``
                         ``my-ao = "my_pkg.method:MyAO"`` (a :class:`~ldbench.methods.base.Method` subclass) or
                         ``"ldbench.effects"`` (an :class:`~ldbench.core.effects.base.EffectSpec` subclass)
                         or ``"ldbench.scenes"`` (a :class:`~ldbench.core.scenes.base.SceneBuilder` subclass);
                         :func:`entry_point_classes` loads them (importlib.metadata).
``module:Class``         ``ldbench run --method my_pkg.method:MyAO`` (or ``methods = ["my_pkg.method:MyAO"]``
                         in a suite) imports the class during development, without installing anything.
                         :func:`register_reference` records it in ``LDBENCH_PLUGIN_METHODS`` (JSON: the
                         reference and the folder it was imported from), which this process and every
                         executor's workers read (the Ray executor forwards ``LDBENCH_*`` variables), so a
                         worker resolves the method by its name like a built-in one.
duplicates               two classes with one name are one :class:`~ldbench.core.errors.LdbenchError` naming
                         both sources (:func:`source_of`: module, and distribution where there is one).
provenance               :func:`provenance` of a class: its module, distribution name and version, and
                         the commit and dirty state of the git repository its module lives in.
=======================  ===========================================================================

Only the standard library and :mod:`ldbench.core.errors` are imported here.
"""
from __future__ import annotations

import importlib
import importlib.metadata
import json
import os
import subprocess
import sys
import tomllib
from functools import lru_cache
from pathlib import Path

from ldbench.core.errors import LdbenchError

METHOD_GROUP = "ldbench.methods"
EFFECT_GROUP = "ldbench.effects"
SCENE_GROUP = "ldbench.scenes"  # entry points only: a scene has no ``package.module:Class`` form
ENV = {METHOD_GROUP: "LDBENCH_PLUGIN_METHODS", EFFECT_GROUP: "LDBENCH_PLUGIN_EFFECTS"}


def is_reference(name: str) -> bool:
    """Whether ``name`` has the ``package.module:Class`` form (not a registered name)."""
    mod, sep, attr = str(name).partition(":")
    return bool(sep and mod and attr and all(p.isidentifier() for p in mod.split("."))
                and all(p.isidentifier() for p in attr.split(".")))


def load_reference(ref: str, base: type, path: str | None = None):
    """The class ``package.module:Class`` (a subclass of ``base``); ``path`` is put on ``sys.path``
    first when given (the folder the driver imported it from). One line when it cannot be loaded."""
    if not is_reference(ref):
        raise LdbenchError(f"{ref!r} is not of the form package.module:Class")
    mod_name, _, attr = ref.partition(":")
    if path and path not in sys.path:
        sys.path.insert(0, path)
    if "" not in sys.path and os.getcwd() not in sys.path:  # `python -m` and console scripts differ here
        sys.path.append(os.getcwd())
    try:
        obj = importlib.import_module(mod_name)
        for part in attr.split("."):
            obj = getattr(obj, part)
    except ImportError as e:
        raise LdbenchError(f"cannot import {ref!r}: {e}") from None
    except AttributeError:
        raise LdbenchError(f"module {mod_name!r} has no {attr!r} (from {ref!r})") from None
    except (Exception, SystemExit) as e:  # the plugin's own code failed at import: name it, no traceback
        lines = [ln.strip() for ln in str(e).splitlines() if ln.strip()]
        raise LdbenchError(f"cannot import {ref!r}: its module raised {type(e).__name__}"
                           + (f": {lines[0][:300]}" if lines else "")) from None
    if not (isinstance(obj, type) and issubclass(obj, base) and getattr(obj, "name", "")):
        raise LdbenchError(f"{ref!r} is not a named {base.__name__} subclass")
    return obj


def _import_root(cls) -> str | None:
    """The ``sys.path`` folder that ``cls``'s top-level package was imported from."""
    top = sys.modules.get(cls.__module__.split(".")[0])
    f = getattr(top, "__file__", None)
    if not f:
        return None
    p = Path(f).resolve().parent
    return str(p.parent if Path(f).name == "__init__.py" else p)


def register_reference(ref: str, base: type, group: str = METHOD_GROUP):
    """Load ``ref`` and add it to this process's (and its workers') development plugins; the class."""
    cls = load_reference(ref, base)
    items = references(group)
    if ref not in [r for r, _ in items]:
        items.append((ref, _import_root(cls)))
        os.environ[ENV[group]] = json.dumps(items)
    return cls


def references(group: str = METHOD_GROUP) -> list:
    """[(reference, import folder)] registered by :func:`register_reference` (here or in the driver)."""
    text = os.environ.get(ENV[group])
    if not text:
        return []
    try:
        items = json.loads(text)
    except ValueError:
        items = None
    ok = isinstance(items, list) and all(
        isinstance(x, list) and len(x) == 2 and isinstance(x[0], str) and (x[1] is None or isinstance(x[1], str))
        for x in items)
    if not ok:
        raise LdbenchError(f"{ENV[group]} is not a JSON list of [reference, folder] pairs (folder a string or "
                           f"null): {text[:100]!r}")
    return [tuple(x) for x in items]


#: {class: (distribution name, version)} of every class loaded through an entry point
_EP_DIST: dict = {}


def _dist_of_entry_point(ep) -> str | None:
    d = getattr(ep, "dist", None)
    return f"{d.metadata['Name']} {d.version}" if d is not None else None


def discovery_key(group: str) -> tuple:
    """What plugin discovery of ``group`` depends on: the import path (each folder with its modification time,
    which an installed or removed distribution changes) and the references registered in the environment.
    Scanning every installed distribution's entry points takes milliseconds (tens of them in a large
    environment), and the registries are read per row and per claim: they are kept per key."""
    def mtime(p):
        try:
            return os.stat(p or ".").st_mtime_ns
        except OSError:
            return None
    return group, tuple((p, mtime(p)) for p in sys.path), os.environ.get(ENV[group]) if group in ENV else None


_EP_CACHE: dict = {}


def entry_point_classes(group: str, base: type) -> list:
    """[(class, source)] of every entry point of ``group``; a broken entry point is one line naming it."""
    key = (discovery_key(group), base)
    if key not in _EP_CACHE:
        _EP_CACHE.clear()  # only the current environment's scan is kept
        _EP_CACHE[key] = _entry_point_classes(group, base)
    return list(_EP_CACHE[key])


def _entry_point_classes(group: str, base: type) -> list:
    out = []
    for ep in importlib.metadata.entry_points(group=group):
        try:
            obj = ep.load()
        except (Exception, SystemExit) as e:  # a plugin's own import error: name the plugin, not a traceback
            raise LdbenchError(f"entry point {ep.name!r} ({ep.value}, group {group}) failed to load: "
                               f"{type(e).__name__}: {e}") from None
        if not (isinstance(obj, type) and issubclass(obj, base) and getattr(obj, "name", None)):
            raise LdbenchError(f"entry point {ep.name!r} ({ep.value}, group {group}) is not a named "
                               f"{base.__name__} subclass")
        dist = _dist_of_entry_point(ep)
        ep_dist = getattr(ep, "dist", None)
        if ep_dist is not None:
            _EP_DIST.setdefault(obj, (ep_dist.metadata["Name"], ep_dist.version))
        out.append((obj, f"{obj.__module__}.{obj.__qualname__} (distribution {dist}, entry point {ep.name})"
                    if dist else f"{obj.__module__}.{obj.__qualname__} (entry point {ep.name})"))
    return out


def source_of(cls) -> str:
    """Where a class comes from, for messages: ``module.Class (distribution NAME VERSION)``."""
    prov = provenance(cls)
    dist = f" (distribution {prov['dist']} {prov['dist_version']})" if prov["dist"] else ""
    return f"{cls.__module__}.{cls.__qualname__}{dist}"


def add_unique(found: dict, sources: dict, cls, source: str, kind: str) -> None:
    """``found[cls.name] = cls``, or one error naming both sources when another class has the name."""
    name = cls.name
    if name in found and found[name] is not cls:
        raise LdbenchError(f"two {kind}s are named {name!r}: {sources[name]} and {source}")
    found[name], sources[name] = cls, source


# ---- provenance ------------------------------------------------------------------------------------
@lru_cache(maxsize=None)
def _module_dist(top: str) -> str | None:
    names = importlib.metadata.packages_distributions().get(top) or []
    return names[0] if names else None


@lru_cache(maxsize=None)
def _git_state(folder: str) -> tuple:
    def git(*args):
        try:
            p = subprocess.run(["git", "-C", folder, *args], capture_output=True, text=True, timeout=10)
        except (OSError, subprocess.SubprocessError):
            return None
        return p.stdout.strip() if p.returncode == 0 else None

    commit = git("rev-parse", "--verify", "-q", "HEAD")
    if not commit:
        return None, None
    status = git("status", "--porcelain")
    return commit, None if status is None else bool(status)


def _ldbench_self(module: str) -> bool:
    return module.split(".")[0] in ("harness", "methods", "references", "ldbench")


def provenance(cls, ldbench: dict | None = None) -> dict:
    """Where ``cls`` comes from: ``module``, ``dist`` and ``dist_version`` (the installed distribution
    holding its top-level package, None for a bare module), ``commit`` and ``dirty`` of the git
    repository holding its module's folder (None outside one). ldbench's own classes get ldbench's
    version and commit (``ldbench``: an :func:`ldbench_info`-like dict already at hand)."""
    module = cls.__module__
    if _ldbench_self(module):
        info = ldbench if ldbench is not None else ldbench_info()
        return {"module": module, "dist": "ldbench", "dist_version": ldbench_version(),
                "commit": info.get("commit"), "dirty": info.get("dirty")}
    dist, version = _EP_DIST.get(cls) or (_module_dist(module.split(".")[0]), None)
    if dist and version is None:
        try:
            version = importlib.metadata.version(dist)
        except importlib.metadata.PackageNotFoundError:
            version = None
    f = getattr(sys.modules.get(module), "__file__", None)
    commit, dirty = _git_state(str(Path(f).resolve().parent)) if f else (None, None)
    if commit is None and dist:  # an installed copy: the commit its build recorded, if any
        commit, dirty = _dist_build_commit(dist)
    return {"module": module, "dist": dist, "dist_version": version, "commit": commit, "dirty": dirty}


def _dist_build_commit(dist: str) -> tuple:
    """(commit, dirty) a distribution's build wrote into a ``build_info.json`` it ships (ldbench does;
    a plugin may too), else from a PEP 610 ``direct_url.json`` of a VCS install; (None, None) otherwise."""
    try:
        d = importlib.metadata.distribution(dist)
    except importlib.metadata.PackageNotFoundError:
        return None, None
    for f in d.files or ():
        if f.name == "build_info.json":
            try:
                info = json.loads(f.read_text())
                return info.get("commit"), info.get("dirty")
            except (OSError, ValueError, AttributeError):
                pass
    try:
        direct = json.loads(d.read_text("direct_url.json") or "null") or {}
        vcs = direct.get("vcs_info") or {}
        if vcs.get("commit_id"):
            return vcs["commit_id"], None
    except ValueError:
        pass
    return None, None


LDBENCH_ROOT = Path(__file__).resolve().parents[2]  # the checkout (ldbench/core/plugins.py)
BUILD_INFO = Path(__file__).resolve().parent / "build_info.json"


def _git(repo_dir, *args) -> str | None:
    try:
        p = subprocess.run(["git", "-C", str(repo_dir), *args], capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return None
    return p.stdout if p.returncode == 0 else None


def git_info_from_env() -> dict:
    """``LDBENCH_COMMIT`` / ``LDBENCH_DIRTY`` (0/1) as :func:`git_info` fields (None when unset)."""
    dirty = os.environ.get("LDBENCH_DIRTY")
    return {"commit": os.environ.get("LDBENCH_COMMIT") or None,
            "dirty": None if dirty is None else dirty == "1", "branch": None}


def _same_dir(a, b) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def git_info(repo_dir=LDBENCH_ROOT) -> dict:
    """Commit, dirty flag and branch of ldbench's own git checkout, whose root is ``repo_dir``.

    The repository counts only when ``repo_dir`` is its top level: an ldbench installed or copied
    inside another repository (a wheel in a project's virtualenv, a vendored copy) must not record
    that repository's commit.

    Returns
    -------
    dict
        ``commit`` (full hash; None before the first commit), ``dirty`` (True when
        ``git status --porcelain`` lists anything, untracked files included), ``branch`` (None on a
        detached HEAD). All None (reported as "unknown") when git is missing or ``repo_dir`` is not the
        top level of a repository. ``LDBENCH_COMMIT`` (and ``LDBENCH_DIRTY`` = 0/1) name them whatever
        ``.git`` says: a working tree copied to a remote GPU runner, without its history or with a stale
        ``.git`` beside it, still records the commit it ran.
    """
    if os.environ.get("LDBENCH_COMMIT"):
        return git_info_from_env()
    top = _git(repo_dir, "rev-parse", "--show-toplevel")
    if top is None or not _same_dir(top.strip(), repo_dir):
        return git_info_from_env()
    status = _git(repo_dir, "status", "--porcelain")
    if status is None:
        return git_info_from_env()
    commit = _git(repo_dir, "rev-parse", "--verify", "-q", "HEAD")
    branch = _git(repo_dir, "symbolic-ref", "-q", "--short", "HEAD")
    return {"commit": commit.strip() if commit else None, "dirty": bool(status.strip()),
            "branch": branch.strip() if branch else None}


@lru_cache(maxsize=1)
def ldbench_version() -> str | None:
    """ldbench's version: pyproject.toml's in a checkout (the tree you run), else the installed metadata."""
    pp = LDBENCH_ROOT / "pyproject.toml"
    if pp.is_file():
        try:
            project = tomllib.loads(pp.read_text()).get("project", {})
            if project.get("name") == "ldbench" and project.get("version"):
                return str(project["version"])
        except (OSError, ValueError):
            pass
    try:
        return importlib.metadata.version("ldbench")
    except importlib.metadata.PackageNotFoundError:
        return None


def ldbench_info() -> dict:
    """``version``, ``commit``, ``dirty`` of the running ldbench: git in a checkout (:func:`git_info`,
    with its LDBENCH_COMMIT override), else what the wheel's build wrote (ldbench/core/build_info.json)."""
    g = git_info(LDBENCH_ROOT)
    commit, dirty = g.get("commit"), g.get("dirty")
    if commit is None and BUILD_INFO.is_file():
        try:
            b = json.loads(BUILD_INFO.read_text())
            commit, dirty = b.get("commit"), b.get("dirty")
        except (OSError, ValueError):
            pass
    return {"version": ldbench_version(), "commit": commit, "dirty": dirty}
