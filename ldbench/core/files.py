"""Writing a file so that no reader ever sees part of it."""
from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

from ldbench.core.errors import LdbenchError


def atomic_write(path, write, *, suffix: str = "") -> Path:
    """Call ``write(tmp)`` with a new temporary path in ``path``'s folder, then rename it over ``path``.

    A reader sees the old file or the new one, never part of one, and two writers of one path never share
    a temporary (``mkstemp``). ``suffix`` ends the temporary's name, for writers that pick a format by it
    (``np.savez`` appends ``.npz`` to any other name). When ``write`` raises, the temporary is removed
    and ``path`` is left as it was. The folder is created if missing; the file is readable by everyone
    (``mkstemp`` makes 0600), as results are meant to be shared. Returns ``path``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=f".tmp{suffix}", dir=path.parent)
    os.close(fd)
    try:
        os.chmod(tmp, 0o644)
        write(Path(tmp))
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    return path


def atomic_write_text(path, text: str) -> Path:
    """:func:`atomic_write` of UTF-8 text."""
    return atomic_write(path, lambda t: t.write_text(text, encoding="utf-8"))


#: The longest file-name component where the file system does not say (``pathconf``): ext4, xfs, btrfs, tmpfs.
NAME_MAX = 255
#: Bytes :func:`atomic_write` adds to a file's name for its temporary (``.NAME.XXXXXXXX.tmp``), before a suffix.
TEMP_EXTRA = len("..") + 8 + len(".tmp")


def check_output_path(path, *, into: bool = False, extra: int = TEMP_EXTRA, flag: str = "--out") -> Path:
    """Refuse, before any work, an output path that no write can succeed at (one line naming it): a name longer
    than its file system takes (with ``extra`` bytes for the temporary or partial name the writer makes beside
    it, e.g. ``.NAME.partial-PID``), a path under a regular file, and a folder where nothing can be created (a
    read-only file system, /proc, /sys, no permission: found by creating and removing a hidden folder there, so
    the answer is the file system's own, for root too). ``into``: ``path`` is a folder the command writes into
    (created when missing), not a file or folder it puts beside its siblings. Every command that writes calls
    this (:class:`ldbench.harness.rundir.RunDir` for the run-like folders, :func:`check_replaceable` for single
    files); a disk that fills up later is one line too (``ldbench.harness.cli.main``). Returns the absolute path.

    Raises
    ------
    LdbenchError
        naming ``flag``, the path and what is wrong."""
    p = Path(os.path.abspath(os.fspath(path)))
    anc = p if into else p.parent
    while not os.path.lexists(anc) and anc != anc.parent:
        anc = anc.parent
    if not anc.is_dir():
        raise LdbenchError(f"{flag} {path}: cannot write under {anc}: it is a file, not a folder")
    try:
        name_max = os.pathconf(anc, "PC_NAME_MAX")
    except (OSError, ValueError):
        name_max = NAME_MAX
    new_parts = p.relative_to(anc).parts if p != anc else ()
    for i, part in enumerate(new_parts):
        room = name_max - (extra if i == len(new_parts) - 1 and not into else 0)
        if len(os.fsencode(part)) > room:
            raise LdbenchError(f"{flag} {path}: cannot write the name {part[:24]}... ({len(os.fsencode(part))} "
                               f"bytes): more than the {room} this file system takes here")
    try:
        os.rmdir(tempfile.mkdtemp(prefix=".ldbench-probe-", dir=anc))
    except OSError as e:
        raise LdbenchError(f"{flag} {path}: cannot write in {anc}: {e.strerror or e}") from None
    return p


def check_replaceable(path, ours) -> None:
    """Refuse to replace ``path`` unless ldbench wrote it: a user's file, or another command's output, is
    never overwritten. ``ours(head)`` says whether the first 4 KiB of an existing file are this output's own
    kind (e.g. its format tag); a missing path is fine; anything not a regular file is refused.

    Raises
    ------
    LdbenchError
        naming the path and what to do."""
    path = Path(path)
    check_output_path(path, flag="output")
    if not os.path.lexists(path):
        return
    if path.is_symlink() or not path.is_file():
        raise LdbenchError(f"{path} exists and is not a file ldbench wrote: choose another output path")
    try:
        with open(path, "rb") as f:
            head = f.read(4096)
    except OSError as e:
        raise LdbenchError(f"cannot read {path}: {e.strerror or e}") from None
    if not ours(head):
        raise LdbenchError(f"{path} exists and ldbench did not write it (it is not this command's output): "
                           "choose another output path, or remove the file")
