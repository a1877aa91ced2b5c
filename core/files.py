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
