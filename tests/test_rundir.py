"""Run directories (ldbench/harness/rundir.py): users' folders are never deleted, replacement is atomic, one
writer at a time, and killed runs leave nothing that a later run does not clean up."""
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from ldbench.core.errors import LdbenchError
from ldbench.harness.rundir import MARKER, RunDir, is_run_dir
from testkit import read_only_parent

ROOT = Path(__file__).resolve().parents[1]


def make_run(d: Path, tag: str = "old") -> Path:
    """The files of a finished run as ldbench writes them (one row, ``tag`` as its suite's name)."""
    from ldbench.harness import records

    d.mkdir(parents=True, exist_ok=True)
    records.write_results([records.make_row(run_id=tag, suite=tag)], d)
    (d / "suite.json").write_text(json.dumps({"name": tag, "source": "", "jobs": 1}))
    return d


def tag(d: Path) -> str:
    return json.loads((d / "suite.json").read_text())["name"]


def dead_pid() -> int:
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


def test_is_run_dir(tmp_path):
    """A run is recognised by what only ldbench writes, not by two file names."""
    assert not is_run_dir(tmp_path)
    (tmp_path / "results.parquet").write_text("")
    (tmp_path / "suite.json").write_text("")
    assert not is_run_dir(tmp_path)  # two empty files of those names: someone else's
    (tmp_path / "suite.json").write_text('{"name": "x", "source": "", "jobs": 1}')
    assert not is_run_dir(tmp_path)  # ... with our suite.json, but no Parquet results
    import pandas as pd
    pd.DataFrame({"a": [1]}).to_parquet(tmp_path / "results.parquet")
    assert not is_run_dir(tmp_path)  # a Parquet file of other columns
    make_run(tmp_path)
    assert is_run_dir(tmp_path)
    (tmp_path / "suite.json").write_bytes(b"\xff\xfe{}")
    assert not is_run_dir(tmp_path)
    make_run(tmp_path)
    (tmp_path / MARKER).write_text("1")
    assert not is_run_dir(tmp_path)  # an unfinished run
    assert not is_run_dir(tmp_path / "results.parquet")


def test_two_empty_files_are_not_a_run_and_stay(tmp_path):
    """--out on a folder holding empty results.parquet and suite.json beside the user's files: refused,
    nothing deleted."""
    out = tmp_path / "mine"
    out.mkdir()
    for f in ("results.parquet", "suite.json"):
        (out / f).write_text("")
    (out / "notes.txt").write_text("mine")
    with pytest.raises(LdbenchError, match="not an ldbench run"):
        RunDir(out).open()
    assert sorted(p.name for p in out.iterdir()) == ["notes.txt", "results.parquet", "suite.json"]


def test_new_run_commits_and_leaves_nothing_else(tmp_path):
    out = tmp_path / "run"
    with RunDir(out) as tmp:
        assert tmp.name == f".run.partial-{os.getpid()}" and tmp.parent == tmp_path
        make_run(tmp, "new")
    assert is_run_dir(out) and tag(out) == "new"
    assert not (out / MARKER).exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]  # no lock, partial or old folder


def test_replaces_a_run_atomically(tmp_path, monkeypatch):
    out = make_run(tmp_path / "run", "old")
    renames = []
    real = os.rename

    def spy(a, b):
        renames.append((Path(a).name, Path(b).name, is_run_dir(out)))
        real(a, b)

    monkeypatch.setattr(os, "rename", spy)
    with RunDir(out) as tmp:
        make_run(tmp, "new")
    pid = os.getpid()
    # old aside first, then the new one in: no moment where DIR holds a half-deleted run
    assert renames == [("run", f".run.old-{pid}", True), (f".run.partial-{pid}", "run", False)]
    assert tag(out) == "new"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]


@pytest.mark.parametrize("setup", ["foreign_dir", "file", "symlink"])
def test_refuses_what_is_not_a_run(tmp_path, setup):
    out = tmp_path / "precious"
    if setup == "foreign_dir":
        out.mkdir()
        (out / "thesis.tex").write_text("years of work")
    elif setup == "file":
        out.write_text("years of work")
    else:
        (tmp_path / "target").mkdir()
        out.symlink_to(tmp_path / "target")
    before = sorted(p.name for p in tmp_path.rglob("*"))
    with pytest.raises(LdbenchError) as e:
        RunDir(out).open()
    assert str(out) in str(e.value) and "\n" not in str(e.value)
    assert sorted(p.name for p in tmp_path.rglob("*")) == before  # nothing created or deleted


def test_empty_folder_may_be_used(tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    with RunDir(out) as tmp:
        make_run(tmp)
    assert is_run_dir(out)


def test_refuses_current_directory(tmp_path, monkeypatch):
    make_run(tmp_path / "r")
    monkeypatch.chdir(tmp_path / "r")
    for out in (".", str(tmp_path / "r"), str(tmp_path)):
        with pytest.raises(LdbenchError, match="current directory"):
            RunDir(out).open()
    assert is_run_dir(tmp_path / "r")


def test_read_only_parent_fails_before_anything(tmp_path):
    with pytest.raises(LdbenchError, match="cannot"):
        RunDir(read_only_parent(tmp_path) / "run").open()


def test_abort_removes_only_its_partial(tmp_path):
    out = make_run(tmp_path / "run", "old")
    with pytest.raises(KeyboardInterrupt):
        with RunDir(out) as tmp:
            make_run(tmp, "new")
            raise KeyboardInterrupt
    assert tag(out) == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]


def test_second_writer_is_refused_and_stale_lock_taken_over(tmp_path):
    out = tmp_path / "run"
    first = RunDir(out)
    first.open()
    with pytest.raises(LdbenchError, match=f"pid {os.getpid()}"):
        RunDir(out).open()
    first.abort()
    # a lock file left by a killed run (its pid is gone, its flock died with it) is taken over
    (tmp_path / ".run.lock").write_text(f"{dead_pid()}\n")
    with RunDir(out) as tmp:
        make_run(tmp)
    assert is_run_dir(out)


def test_sweeps_stale_partials_but_not_foreign_folders(tmp_path):
    pid = dead_pid()
    stale = tmp_path / f".run.partial-{pid}"
    stale.mkdir()
    (stale / MARKER).write_text(str(pid))
    (stale / "half.exr").write_text("x")
    unmarked = tmp_path / f".run.partial-{pid + 1 if pid + 1 != os.getpid() else pid + 2}"
    unmarked.mkdir()  # matches the name, but ldbench did not make it
    other = tmp_path / f".other.partial-{pid}"
    other.mkdir()
    (other / MARKER).write_text(str(pid))
    live = tmp_path / f".run.partial-{os.getppid()}"  # a live process's: left alone
    live.mkdir()
    (live / MARKER).write_text("x")
    with RunDir(tmp_path / "run") as tmp:
        make_run(tmp)
    assert not stale.exists()
    assert unmarked.exists() and other.exists() and live.exists()


def test_old_run_of_a_killed_commit_is_restored(tmp_path):
    """Killed between "old aside" and "new in": the next run puts the old run back first."""
    old = make_run(tmp_path / f".run.old-{dead_pid()}", "old")
    rd = RunDir(tmp_path / "run")
    rd.open()
    assert not old.exists() and tag(tmp_path / "run") == "old"
    rd.abort()
    assert tag(tmp_path / "run") == "old"


def test_concurrent_cli_run_into_same_out_exits_2(tmp_path):
    """A second `ldbench run` into a DIR another process is writing: one line, exit 2, and the first
    run's partial folder is untouched."""
    out = tmp_path / "run"
    holder = subprocess.Popen([sys.executable, "-c", textwrap.dedent(f"""
        import sys, time
        from ldbench.harness.rundir import RunDir
        RunDir({str(out)!r}).open(); print("locked", flush=True); time.sleep(60)""")],
        cwd=ROOT, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "locked"
        p = subprocess.run([sys.executable, "-m", "ldbench.harness.cli", "run", "--scene", "cornell", "--method",
                            "direct-raster", "--effect", "direct", "--size", "16x16", "--spp", "4",
                            "--out", str(out), "--no-progress"], cwd=ROOT, capture_output=True, text=True,
                           timeout=300)
        assert p.returncode == 2, p.stderr
        lines = p.stderr.strip().splitlines()
        assert len(lines) == 1 and "another ldbench run" in lines[0], p.stderr
        assert (tmp_path / f".run.partial-{holder.pid}").is_dir() and not out.exists()
    finally:
        holder.kill()
        holder.wait()


def test_every_file_ldbench_writes_into_a_run_keeps_it_replaceable(tmp_path):
    """A run that reproduce, report, compare or score wrote into stays an ldbench run a second reproduce
    (a nightly's second night) or run may replace: reproduce.json among them."""
    for name in ("reproduce.json", "reproduce.md", "compare.md", "summary.md", "index.html", "results.csv"):
        out = make_run(tmp_path / name.replace(".", "-"), "old")
        (out / name).write_text("{}")
        with RunDir(out) as tmp:
            make_run(tmp, "new")
        assert tag(out) == "new"


# A run committed over an older one by a process that SIGKILLs itself at its STEP-th file-system change
# inside RunDir.commit (a rename, an unlink, a rmdir: every one the commit and its clean-up make, counted).
KILLED_COMMIT = """
import json, os, signal, sys
from pathlib import Path
sys.path.insert(0, sys.argv[3])
from test_rundir import make_run
from ldbench.harness.rundir import RunDir

step, out = int(sys.argv[1]), Path(sys.argv[2])
rd = RunDir(out)
make_run(rd.open(), "new")
count = [0]
def counted(f):
    def g(*a, **k):
        count[0] += 1
        if count[0] == step:
            os.kill(os.getpid(), signal.SIGKILL)
        return f(*a, **k)
    return g
for name in ("rename", "replace", "unlink", "rmdir"):
    setattr(os, name, counted(getattr(os, name)))
rd.commit()
print(count[0])
"""


def test_a_commit_killed_at_any_step_leaves_the_old_run_or_the_new(tmp_path):
    """SIGKILL at each file-system change of a commit in turn (marker removed, old run aside, new run in, each
    file of the old run deleted): a reader finds the old run or the new one at DIR, or nothing, and never a
    half; nothing else is visible; the next run into DIR sweeps what is left and finds the old run or the new
    whole, and after its own commit nothing stale remains."""
    def attempt(step: int, out: Path) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-c", KILLED_COMMIT, str(step), str(out), str(ROOT / "tests")],
                              cwd=ROOT, capture_output=True, text=True, timeout=120)

    whole = attempt(0, make_run(tmp_path / "probe" / "run", "old"))  # step 0: never killed; counts the steps
    assert whole.returncode == 0, whole.stderr[-2000:]
    steps = int(whole.stdout.split()[-1])
    assert steps >= 4, steps  # marker, old aside, new in, at least one file of the old run
    for step in range(1, steps + 1):
        parent = tmp_path / f"s{step}"
        out = make_run(parent / "run", "old")
        p = attempt(step, out)
        assert p.returncode == -9, (step, p.stderr[-2000:])
        if out.exists():
            assert is_run_dir(out) and tag(out) in ("old", "new"), step
        visible = [x.name for x in parent.iterdir() if not x.name.startswith(".")]
        assert visible in ([], ["run"]), (step, visible)
        rd = RunDir(out)
        make_run(rd.open(), "next")  # sweeps first
        assert is_run_dir(out) and tag(out) in ("old", "new"), step
        rd.commit()
        assert tag(out) == "next" and sorted(x.name for x in parent.iterdir()) == ["run"], (
            step, sorted(x.name for x in parent.iterdir()))
