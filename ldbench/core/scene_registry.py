"""Registered real scenes: the registry (data in ``scene_registry.toml``), the checksummed cache, fetching.

=====================  ==========================================================================
``registry()``         name -> :class:`Entry` (title, licence, source, files with SHA-256, how to load
                       it, camera and spot light), read from ``scene_registry.toml``
``scenes_dir()``       the cache: ``$LDBENCH_SCENES``, else ``$XDG_CACHE_HOME/ldbench/scenes``, else
                       ``~/.cache/ldbench/scenes``; one folder per scene (``Entry.folder``)
``status(entry)``      ``"fetched"`` / ``"incomplete"`` / ``"not fetched"`` (file sizes only: cheap)
``verified_root(e)``   the scene's folder after checking every file's SHA-256 (what loading uses)
``fetch(entry, src)``  download (``src`` None) or copy from a local mirror laid out like the cache
=====================  ==========================================================================

A fetch builds the folder under a temporary name beside it, checks every file's SHA-256, writes a
``.ldbench-fetch.json`` marker and only then renames it into place, so the cache never holds a half
written or unverified scene. A folder that is in the way and has no marker was not written by ldbench
and is never deleted. Building a :class:`~ldbench.core.scene.Scene` from the files is
:func:`ldbench.core.scenes.build_registered`.
"""
from __future__ import annotations

import functools
import gzip
import hashlib
import io
import json
import os
import shutil
import time
import tomllib
import urllib.error
import urllib.request
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

from .errors import LdbenchError
from .scene import Camera, SpotLight

DATA = Path(__file__).resolve().parent / "scene_registry.toml"
MARKER = ".ldbench-fetch.json"
LOAD_KINDS = ("mesh", "parts", "object", "xml")
DOWNLOAD_TIMEOUT_S = 60


@dataclass(frozen=True)
class FileSpec:
    path: str  # inside the scene's folder
    size: int
    sha256: str
    url: str = ""  # "" = derived file without a public download
    unpack: str = ""  # "", "gzip" or "zip" (the member with this file's name)


@dataclass(frozen=True)
class Entry:
    name: str
    title: str
    licence: str
    source: str
    papers: tuple
    folder: str
    triangles: int
    notes: str
    load: dict
    camera: Camera | None  # None: the scene file's camera
    light: SpotLight
    files: tuple
    warning: str = ""
    d_max: float | None = None  # the AO distance of an ad-hoc run without --d-max (ldbench.core.scenes.default_d_max)
    views: dict = field(default_factory=dict)  # name -> Camera: other viewpoints (`NAME:view=...`)


def _entry(name: str, d: dict) -> Entry:
    try:
        load = dict(d["load"])
        if load.get("kind") not in LOAD_KINDS:
            raise ValueError(f"load.kind must be one of {LOAD_KINDS}")
        cam = d.get("camera")
        files = tuple(FileSpec(**f) for f in d["files"])
        for f in files:
            if f.unpack not in ("", "gzip", "zip") or len(f.sha256) != 64 or Path(f.path).is_absolute() \
                    or ".." in Path(f.path).parts:
                raise ValueError(f"bad file entry {f.path!r}")
        return Entry(name=name, title=d["title"], licence=d["licence"], source=d["source"],
                     papers=tuple(d.get("papers", ())), folder=d["folder"], triangles=int(d["triangles"]),
                     notes=" ".join(d.get("notes", "").split()), load=load,
                     camera=Camera(**cam) if cam else None, light=SpotLight(**d["light"]), files=files,
                     warning=d.get("warning", ""),
                     d_max=None if d.get("d_max") is None else float(d["d_max"]),
                     views={k: Camera(**v) for k, v in d.get("views", {}).items()})
    except (KeyError, TypeError, ValueError, LdbenchError) as e:
        raise LdbenchError(f"scene registry {DATA}: bad entry {name!r}: {e}") from None


@functools.cache
def registry() -> dict[str, Entry]:
    """name -> :class:`Entry`, in the file's order."""
    data = tomllib.loads(DATA.read_text(encoding="utf-8"))
    return {name: _entry(name, d) for name, d in data.items()}


def get(name: str) -> Entry:
    reg = registry()
    if name not in reg:
        raise LdbenchError(f"unknown registered scene {name!r} (registered: {', '.join(reg)})")
    return reg[name]


def scenes_dir() -> Path:
    """The scene cache: ``$LDBENCH_SCENES``, else the user cache dir (XDG) + ``ldbench/scenes``."""
    env = os.environ.get("LDBENCH_SCENES")
    if env:
        return Path(env).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "ldbench" / "scenes"


def fetch_hint(name: str) -> str:
    e = get(name)
    mirror = f"ldbench scenes fetch {name} --from MIRROR (copies it from a local mirror holding {e.folder}/)"
    if any(not f.url for f in e.files):
        return mirror + "; it has derived files with no public download"
    return f"ldbench scenes fetch {name} (downloads it), or {mirror}"


# --------------------------------------------------------------------------------------------------
# checking


def sha256_file(path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def status(entry: Entry, root: Path | None = None) -> str:
    """``"fetched"`` when every file is present with its registered size, ``"incomplete"`` when some
    are, else ``"not fetched"``. Sizes only (checksums are checked by :func:`verified_root`)."""
    folder = (root or scenes_dir()) / entry.folder
    ok = [(folder / f.path).is_file() and (folder / f.path).stat().st_size == f.size for f in entry.files]
    return "fetched" if all(ok) else "incomplete" if any(ok) else "not fetched"


_verified: dict = {}  # (path, size, mtime_ns) -> sha256, so one process hashes a file once


def _check(path: Path, f: FileSpec) -> str | None:
    """None when ``path`` holds ``f``'s bytes, else what is wrong with it."""
    if not path.is_file():
        return "missing"
    st = path.stat()
    if st.st_size != f.size:
        return f"{st.st_size} bytes, expected {f.size}"
    key = (str(path), st.st_size, st.st_mtime_ns)
    if key not in _verified:
        _verified[key] = sha256_file(path)
    if _verified[key] != f.sha256:
        return f"SHA-256 {_verified[key][:16]}..., expected {f.sha256[:16]}..."
    return None


def verified_root(name: str, root: Path | None = None) -> Path:
    """The folder of fetched scene ``name`` after checking every file's SHA-256; otherwise one
    :class:`LdbenchError` line saying how to fetch it (or that the copy is corrupt)."""
    entry = get(name)
    folder = (root or scenes_dir()) / entry.folder
    if status(entry, root) == "not fetched":
        raise LdbenchError(f"scene {name!r} is not fetched (looked in {folder}): run {fetch_hint(name)}")
    for f in entry.files:
        why = _check(folder / f.path, f)
        if why:
            raise LdbenchError(f"scene {name!r}: {folder / f.path} is {why} (corrupt or incomplete copy): "
                               f"fetch it again with ldbench scenes fetch {name}")
    return folder


# --------------------------------------------------------------------------------------------------
# fetching


def _download(entry: Entry, f: FileSpec, dst: Path):
    if not f.url:
        raise LdbenchError(f"scene {entry.name!r}: {f.path} is a derived file with no public download; "
                           f"copy it from a local mirror: ldbench scenes fetch {entry.name} --from MIRROR")
    try:
        with urllib.request.urlopen(f.url, timeout=DOWNLOAD_TIMEOUT_S) as r:
            data = r.read()
    except (urllib.error.URLError, OSError, ValueError) as e:
        reason = getattr(e, "reason", None) or e
        raise LdbenchError(f"cannot download scene {entry.name!r} ({f.url}: {reason}); without network, "
                           f"copy it from a local mirror: ldbench scenes fetch {entry.name} --from MIRROR") from None
    try:
        if f.unpack == "gzip":
            data = gzip.decompress(data)
        elif f.unpack == "zip":
            with zipfile.ZipFile(io.BytesIO(data)) as z:
                members = [m for m in z.namelist() if Path(m).name == Path(f.path).name]
                if len(members) != 1:
                    raise ValueError(f"no single member named {Path(f.path).name} in the archive")
                data = z.read(members[0])
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as e:
        raise LdbenchError(f"cannot unpack {f.url} for scene {entry.name!r}: {e}") from None
    dst.write_bytes(data)


def _copy(entry: Entry, f: FileSpec, mirror: Path, dst: Path):
    src = mirror / entry.folder / f.path
    if not src.is_file():
        raise LdbenchError(f"scene {entry.name!r}: {src} not found (a mirror holds one folder per scene, "
                           f"here {entry.folder}/)")
    shutil.copyfile(src, dst)


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return True
    return True


def _sweep_stale(root: Path, folder: str):
    """Remove the temporary folders of fetches whose process is gone (killed mid-fetch)."""
    for p in list(root.glob(f".{folder}.partial-*")) + list(root.glob(f".{folder}.old-*")):
        pid = p.name.rsplit("-", 1)[-1]
        if pid.isdigit() and int(pid) != os.getpid() and not _pid_alive(int(pid)):
            shutil.rmtree(p, ignore_errors=True)


def fetch(name: str, source: Path | str | None = None, root: Path | None = None, log=print) -> Path:
    """Put scene ``name`` into the cache (downloading it, or copying it from the mirror ``source``) and
    verify every file's SHA-256. Returns the scene's folder. Atomic: nothing is left half written."""
    entry = get(name)
    root = Path(root or scenes_dir())
    target = root / entry.folder
    if status(entry, root) == "fetched":
        try:
            verified_root(name, root)
            log(f"{name}: already fetched, checksums verified ({target})")
            return target
        except LdbenchError:
            pass  # corrupt: fetch it again below
    if target.exists() and not (target / MARKER).is_file():
        raise LdbenchError(f"{target} is in the way and was not written by ldbench; move it away, or set "
                           f"LDBENCH_SCENES to another folder")
    mirror = Path(source) if source is not None else None
    if mirror is not None and not mirror.is_dir():
        raise LdbenchError(f"--from {mirror}: not a directory")
    if mirror is None and any(not f.url for f in entry.files):
        derived = [f.path for f in entry.files if not f.url]
        raise LdbenchError(f"scene {name!r} cannot be downloaded: {len(derived)} of its {len(entry.files)} files "
                           f"(e.g. {derived[0]}) are derived, with no public download; copy it from a local "
                           f"mirror: ldbench scenes fetch {name} --from MIRROR")
    try:
        root.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise LdbenchError(f"cannot create the scene cache {root}: {e.strerror or e}") from None
    _sweep_stale(root, entry.folder)
    tmp = root / f".{entry.folder}.partial-{os.getpid()}"
    shutil.rmtree(tmp, ignore_errors=True)
    try:
        for f in entry.files:
            dst = tmp / f.path
            dst.parent.mkdir(parents=True, exist_ok=True)
            if mirror is not None:
                _copy(entry, f, mirror, dst)
            else:
                log(f"{name}: downloading {f.url}")
                _download(entry, f, dst)
            why = _check(dst, f)
            if why:
                origin = mirror / entry.folder / f.path if mirror is not None else f.url
                raise LdbenchError(f"scene {name!r}: checksum mismatch for {origin}: {why}; nothing was "
                                   f"written to the cache")
        (tmp / MARKER).write_text(json.dumps({
            "scene": name, "from": str(mirror) if mirror is not None else "download",
            "time": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
            "files": {f.path: f.sha256 for f in entry.files}}, indent=1) + "\n")
        old = None
        if target.exists():  # ours (marked) but stale or corrupt: swap, then delete the old copy
            old = root / f".{entry.folder}.old-{os.getpid()}"
            target.rename(old)
        try:
            tmp.rename(target)
        except OSError:
            if old is not None:
                old.rename(target)
            raise
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    except OSError as e:
        raise LdbenchError(f"cannot write scene {name!r} into {root}: {e.strerror or e}") from None
    finally:
        shutil.rmtree(tmp, ignore_errors=True)  # our temporary folder (gone after a successful rename)
    n = len(entry.files)
    log(f"{name}: fetched into {target} ({n} file{'s' if n != 1 else ''}, checksums verified)")
    return target
