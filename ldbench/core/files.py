"""Writing a file so that no reader ever sees part of it."""
from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path


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


def check_replaceable(path, ours) -> None:
    """Refuse to replace ``path`` unless ldbench wrote it: a user's file, or another command's output, is
    never overwritten. ``ours(head)`` says whether the first 4 KiB of an existing file are this output's own
    kind (e.g. its format tag); a missing path is fine; anything not a regular file is refused.

    Raises
    ------
    LdbenchError
        naming the path and what to do."""
    from ldbench.core.errors import LdbenchError

    path = Path(path)
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
