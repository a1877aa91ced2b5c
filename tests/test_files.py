"""Atomic writes (ldbench/core/files.py): a reader sees the old file or the new one, never part of one."""
import stat
import threading

import numpy as np
import pytest

from ldbench.core.files import atomic_write, atomic_write_text


def test_the_file_replaces_the_old_one_whole(tmp_path):
    p = tmp_path / "sub" / "a.txt"
    atomic_write_text(p, "first")
    atomic_write_text(p, "second")
    assert p.read_text() == "second"
    assert stat.S_IMODE(p.stat().st_mode) == 0o644
    assert [q.name for q in p.parent.iterdir()] == ["a.txt"]


def test_a_failed_write_leaves_the_old_file_and_no_temporary(tmp_path):
    p = tmp_path / "a.bin"
    p.write_bytes(b"old")

    def half(t):
        t.write_bytes(b"ne")
        raise RuntimeError("disk full")

    with pytest.raises(RuntimeError):
        atomic_write(p, half)
    assert p.read_bytes() == b"old" and [q.name for q in tmp_path.iterdir()] == ["a.bin"]


def test_suffix_keeps_numpy_from_renaming_the_temporary(tmp_path):
    p = tmp_path / "x.npz"
    atomic_write(p, lambda t: np.savez(t, a=np.arange(3)), suffix=".npz")
    assert np.array_equal(np.load(p)["a"], np.arange(3))
    assert [q.name for q in tmp_path.iterdir()] == ["x.npz"]


def test_concurrent_writers_of_one_path_never_share_a_temporary(tmp_path):
    p = tmp_path / "shared.txt"
    texts = [str(i) * 20000 for i in range(8)]
    errors = []

    def writer(text):
        try:
            for _ in range(20):
                atomic_write_text(p, text)
        except Exception as e:  # noqa: BLE001 - reported below
            errors.append(e)

    threads = [threading.Thread(target=writer, args=(t,)) for t in texts]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors and p.read_text() in texts
    assert [q.name for q in tmp_path.iterdir()] == ["shared.txt"]
