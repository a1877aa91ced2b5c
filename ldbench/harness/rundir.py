"""Run directories: written under a temporary name, replaced atomically, never someone else's folder.

A run directory (``ldbench run --out DIR``) holds ``results.parquet`` and ``suite.json`` written by
ldbench: a Parquet table with the results schema and a JSON object naming the suite and its job count
(see :func:`is_run_dir`; two files of those names with other contents are someone else's).
:class:`RunDir` is the only code that creates, replaces or deletes one:

* **Refuse** (one-line :class:`~ldbench.core.errors.LdbenchError`) when DIR exists and is neither an
  ldbench run nor an empty folder, when it is a run that also holds a top-level entry ldbench never writes
  (:data:`RUN_ENTRIES`: a user's notes beside the results), when it is a file or a symbolic link, when it is the current
  directory or contains it, and when its parent cannot be written. All of this is checked by
  :meth:`RunDir.open`, before anything is rendered.
* **Lock**: ``.DIR.lock`` beside DIR, held with ``flock`` for the whole run (the pid inside is
  informational). The kernel drops the lock when its process dies, so a stale lock file left by a
  killed run is simply taken over; a second live run into the same DIR stops with one line.
* **Write** into ``.DIR.partial-PID`` (with a marker file ``.ldbench-partial``, so that only folders
  ldbench made are ever swept).
* **Sweep**, under the lock: ``.DIR.partial-PID`` folders with the marker whose process is gone are
  deleted; a ``.DIR.old-PID`` left by a run killed during its commit is deleted when DIR exists, and
  renamed back to DIR when it does not (it is the last complete run).
* **Commit**: move the old DIR aside (``.DIR.old-PID``), rename the partial folder in, then delete
  the old run. A reader sees either the old or the new complete run, never a half-deleted one.
* **Abort** (any exception, including KeyboardInterrupt): delete only this run's partial folder.

Usage (the runner)::

    rd = RunDir(out_dir)
    tmp = rd.open()            # checks, lock, sweep, partial folder
    try:
        ...write into tmp...
        rd.commit()
    except BaseException:
        rd.abort()
        raise

or ``with RunDir(out_dir) as tmp: ...`` (commit on a clean exit, abort on an exception).
"""
from __future__ import annotations

import errno
import fcntl
import json
import os
import re
import shutil
from pathlib import Path

from ldbench.core.errors import LdbenchError
from ldbench.core.files import check_output_path
from .records import PARTIAL_MARKER as MARKER, check_columns  # noqa: F401 (records refuses what carries it)

# Heavy: pyarrow is imported by is_run_dir() alone, to read a results file's schema.

RUN_FILES = ("results.parquet", "suite.json")
#: Every top-level entry that ldbench writes into a run directory (the runner, ``report``, ``compare``,
#: ``reproduce``, ``score``); a run holding anything else also holds a user's file and is not replaced.
RUN_ENTRIES = frozenset(RUN_FILES + ("results.csv", "summary.md", "index.html", "reproduce.md", "reproduce.json",
                                     "compare.md", "images", "figures"))


#: The name of what a :class:`RunDir` keeps beside DIR while it writes or commits (``.DIR.partial-PID``,
#: ``.DIR.old-PID``): never a run or a question of its own, whatever step a kill left it at.
STALE_NAME = re.compile(r"^\..+\.(partial|old)-\d+$")


def foreign_entries(path, entries=RUN_ENTRIES) -> list[str]:
    """Top-level entries of the folder ``path`` that ldbench does not write into it (sorted)."""
    return sorted(e.name for e in Path(path).iterdir() if e.name not in entries)


#: The keys of the ``suite.json`` ldbench writes (:func:`ldbench.harness.executors.run_jobs`).
SUITE_KEYS = ("name", "source", "jobs")


def is_run_dir(path) -> bool:
    """True if ``path`` is a finished ldbench run: a directory (not a link, no :data:`MARKER`) holding
    the ``suite.json`` ldbench writes (a JSON object with :data:`SUITE_KEYS`) and a ``results.parquet``
    whose Parquet schema has the results columns (:func:`ldbench.harness.records.check_columns`). Only the
    files' headers are read."""
    p = Path(path)
    if not p.is_dir() or p.is_symlink() or (p / MARKER).exists():
        return False
    if not all((p / f).is_file() and not (p / f).is_symlink() for f in RUN_FILES):
        return False
    try:
        suite = json.loads((p / "suite.json").read_bytes()[:1 << 20])
        if not isinstance(suite, dict) or not all(k in suite for k in SUITE_KEYS):
            return False
        import pyarrow.parquet as pq

        check_columns(pq.read_schema(p / "results.parquet").names, str(p))
    except (OSError, ValueError, LdbenchError):  # unreadable, not JSON, not Parquet (ArrowInvalid), foreign
        return False
    return True


class Kind:
    """A kind of output folder that :class:`RunDir` writes: how to recognise one ldbench wrote
    (``is_ours``), every top-level entry ldbench writes into it (``entries``), and how messages name it."""

    def __init__(self, what: str, is_ours, entries: frozenset, proof: str):
        self.what, self.is_ours, self.entries, self.proof = what, is_ours, frozenset(entries), proof


RUN = Kind("an ldbench run", is_run_dir, RUN_ENTRIES, f"no {' and '.join(RUN_FILES)} written by ldbench")

#: Every top-level entry ``ldbench export`` writes into a question folder (ldbench/harness/export.py)
QUESTION_ENTRIES = frozenset(("question.json", "scene.xml", "scene.ply", "meshes", "camera.json", "light.json",
                              "rays.npz", "batch.npz"))
QUESTION_KEYS = ("scene", "effect", "width", "height", "spp", "seed", "files", "ldbench_version")


def is_question_dir(path) -> bool:
    """True if ``path`` is a finished ``ldbench export`` folder: a directory (not a link, no :data:`MARKER`)
    whose ``question.json`` is the JSON object export writes (:data:`QUESTION_KEYS`)."""
    p = Path(path)
    if not p.is_dir() or p.is_symlink() or (p / MARKER).exists():
        return False
    q = p / "question.json"
    if not q.is_file() or q.is_symlink():
        return False
    try:
        d = json.loads(q.read_bytes()[:1 << 20])
    except (OSError, ValueError):
        return False
    return isinstance(d, dict) and all(k in d for k in QUESTION_KEYS)


QUESTION = Kind("an ldbench question", is_question_dir, QUESTION_ENTRIES, "no question.json written by ldbench export")


def _replaceable(p: Path, kind: Kind = RUN) -> bool:
    """An existing DIR that may be replaced: a folder of this kind ldbench wrote holding only what ldbench
    writes, or an empty folder."""
    if p.is_symlink() or not p.is_dir():
        return False
    return (kind.is_ours(p) and not foreign_entries(p, kind.entries)) or not any(p.iterdir())


def _pid_alive(pid: int) -> bool:
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # someone else's live process
        return True
    return True


def _why(e: OSError) -> str:
    return e.strerror or str(e)


class RunDir:
    """One run's output directory ``out`` (see the module docstring)."""

    def __init__(self, out, kind: Kind = RUN):
        self.kind = kind
        self.out = Path(os.path.abspath(os.fspath(out)))
        self.parent = self.out.parent
        name = self.out.name
        self.pid = os.getpid()
        self.lock_path = self.parent / f".{name}.lock"
        self.partial = self.parent / f".{name}.partial-{self.pid}"
        self.old = self.parent / f".{name}.old-{self.pid}"
        self._stale = re.compile(rf"^\.{re.escape(name)}\.(partial|old)-(\d+)$")
        self._lock_fd: int | None = None
        self._opened = False

    # ---- checks -----------------------------------------------------------------------------
    def check(self) -> None:
        """Refuse an ``--out`` that is not ours to replace, or where nothing can be written (raises
        LdbenchError). Creates nothing (what :func:`~ldbench.core.files.check_output_path` probes is removed)."""
        out = self.out
        if not out.name or out.name in (".", ".."):
            raise LdbenchError(f"--out {out}: not a usable run directory name")
        check_output_path(out, extra=len(self.partial.name) - len(out.name))  # under a file, /proc, too long
        cwd = Path(os.path.abspath(os.getcwd()))
        if out == cwd or out in cwd.parents:
            raise LdbenchError(f"--out {out} is the current directory or contains it; give a new folder")
        if out.is_symlink():
            raise LdbenchError(f"--out {out} is a symbolic link; give the folder it points to")
        kind = self.kind
        if out.exists():
            if not out.is_dir():
                raise LdbenchError(f"--out {out} exists and is not a directory")
            if kind.is_ours(out) and foreign_entries(out, kind.entries):
                extra = foreign_entries(out, kind.entries)
                raise LdbenchError(f"--out {out} is {kind.what} that also holds files ldbench did not write "
                                   f"({', '.join(extra[:3])}{', ...' if len(extra) > 3 else ''}); move them or "
                                   f"give another folder: not replacing it")
            if not _replaceable(out, kind):
                raise LdbenchError(f"--out {out} exists and is not {kind.what} ({kind.proof}); not replacing it")
        if self.parent.exists() and not self.parent.is_dir():
            raise LdbenchError(f"--out {out}: {self.parent} is not a directory")

    # ---- lock --------------------------------------------------------------------------------
    def _lock(self) -> None:
        while True:
            try:
                fd = os.open(self.lock_path, os.O_RDWR | os.O_CREAT, 0o644)
            except OSError as e:
                raise LdbenchError(f"cannot write to {self.parent}: {_why(e)}")
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError as e:
                if e.errno not in (errno.EWOULDBLOCK, errno.EACCES, errno.EAGAIN):
                    os.close(fd)
                    raise LdbenchError(f"cannot lock {self.lock_path}: {_why(e)}")
                try:
                    holder = os.read(fd, 64).decode(errors="replace").strip() or "?"
                finally:
                    os.close(fd)
                raise LdbenchError(f"another ldbench run (pid {holder}) is writing {self.out}; "
                                   f"wait for it or choose another --out")
            # The file may have been unlinked by its previous holder between our open and flock:
            # then we hold a lock on a dead inode, and must retry on the current file.
            try:
                same = os.stat(self.lock_path).st_ino == os.fstat(fd).st_ino
            except FileNotFoundError:
                same = False
            if same:
                break
            os.close(fd)
        os.ftruncate(fd, 0)
        os.write(fd, f"{self.pid}\n".encode())
        self._lock_fd = fd

    def _unlock(self) -> None:
        if self._lock_fd is None:
            return
        try:
            os.unlink(self.lock_path)  # while still holding it (see the inode check in _lock)
        except OSError:
            pass
        os.close(self._lock_fd)
        self._lock_fd = None

    # ---- sweep -------------------------------------------------------------------------------
    def sweep(self) -> None:
        """Remove what killed runs into this DIR left behind (call with the lock held)."""
        try:
            entries = list(self.parent.iterdir())
        except OSError:
            return
        for p in entries:
            m = self._stale.match(p.name)
            if not m or p.is_symlink() or not p.is_dir():
                continue
            kind, pid = m.group(1), int(m.group(2))
            if pid != self.pid and _pid_alive(pid):
                continue
            if kind == "partial":
                # with its marker; or complete, the marker already gone: its commit was killed before the
                # rename in (the old run, moved aside, is put back below)
                if (p / MARKER).is_file() or (self.kind.is_ours(p) and not foreign_entries(p, self.kind.entries)):
                    shutil.rmtree(p, ignore_errors=True)
            elif _replaceable(p, self.kind):  # an old run moved aside by a commit that was killed
                if self.out.exists() or self.out.is_symlink():
                    _remove_run(p, self.kind)
                else:
                    os.rename(p, self.out)
            elif (p / MARKER).is_file() and not foreign_entries(p, self.kind.entries | {MARKER}):
                shutil.rmtree(p, ignore_errors=True)  # a replaced run whose removal was killed midway

    # ---- life cycle --------------------------------------------------------------------------
    def open(self) -> Path:
        """Check ``out``, take the lock, sweep, create the partial folder; returns the partial folder."""
        if self._opened:
            raise RuntimeError("RunDir.open called twice")
        self.check()
        try:
            self.parent.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise LdbenchError(f"cannot create {self.parent}: {_why(e)}")
        self._lock()
        try:
            self.check()  # again, under the lock
            self.sweep()
            self.partial.mkdir()
            (self.partial / MARKER).write_text(f"{self.pid}\n")
        except BaseException as e:
            if self.partial.is_dir():
                shutil.rmtree(self.partial, ignore_errors=True)
            self._unlock()
            if isinstance(e, OSError):
                raise LdbenchError(f"cannot write to {self.parent}: {_why(e)}") from e
            raise
        self._opened = True
        return self.partial

    def commit(self) -> Path:
        """Replace ``out`` by the partial folder (old run aside, new one in, old one deleted)."""
        if not self._opened:
            raise RuntimeError("RunDir.commit before open")
        try:
            if (self.out.exists() or self.out.is_symlink()) and not _replaceable(self.out, self.kind):
                raise LdbenchError(f"--out {self.out} was changed meanwhile and is no longer {self.kind.what}; "
                                   f"not replacing it")
            (self.partial / MARKER).unlink()
            moved = False
            if self.out.exists():
                os.rename(self.out, self.old)
                moved = True
            try:
                os.rename(self.partial, self.out)
            except BaseException:
                if moved:
                    os.rename(self.old, self.out)
                raise
            _fsync_dir(self.parent)
            if moved:
                _remove_run(self.old, self.kind)
        except OSError as e:
            raise LdbenchError(f"cannot move the run into {self.out}: {_why(e)}")
        finally:
            self._opened = False
            self._unlock()
        return self.out

    def abort(self) -> None:
        """Delete this run's partial folder (and nothing else); release the lock."""
        try:
            if self.partial.is_dir() and not self.partial.is_symlink():
                shutil.rmtree(self.partial, ignore_errors=True)
        finally:
            self._opened = False
            self._unlock()

    def __enter__(self) -> Path:
        return self.open()

    def __exit__(self, exc_type, exc, tb):
        if exc_type is None:
            self.commit()
        else:
            self.abort()
        return False


def _remove_run(p: Path, kind: Kind = RUN) -> None:
    """Delete a replaced folder of this kind (rmtree) or an empty folder (rmdir); anything else is left alone."""
    if kind.is_ours(p) and not foreign_entries(p, kind.entries):
        # Marked first: a removal killed midway leaves a folder no reader takes for a run, and the next
        # sweep finishes it (rmtree's order would otherwise leave an unrecognisable half behind for good).
        (p / MARKER).write_text(f"{os.getpid()}\n")
        shutil.rmtree(p, ignore_errors=True)
    else:
        try:
            os.rmdir(p)
        except OSError:
            pass


def _fsync_dir(d: Path) -> None:
    """Make the renames durable (best effort: not every file system supports it)."""
    try:
        fd = os.open(d, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)
