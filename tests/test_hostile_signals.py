"""Signals at hostile moments: Ctrl-C while Dr.Jit/Mitsuba start (inside their C++ start-up) is the one-line
"interrupted", exit 130, nothing left behind (ldbench/core/signals.py); SIGKILL at any step of an export
leaves the previous question intact or recoverable, and nothing a reader accepts as a question."""
import json
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

# Ctrl-C (SIGINT from another thread, as a terminal's) a moment after `import drjit` begins: inside the
# extension's initialisation, where a KeyboardInterrupt used to come out as a NameError, "no usable Mitsuba
# variant" or SIGABRT at exit.
SIGINT_IN_DRJIT_START = """
import importlib.abc, os, signal, sys, threading
from ldbench.harness.cli import main

class SigintWhenDrjitLoads(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name == "drjit":
            sys.meta_path.remove(self)
            threading.Timer(0.05, os.kill, (os.getpid(), signal.SIGINT)).start()
        return None

sys.meta_path.insert(0, SigintWhenDrjitLoads())
sys.exit(main(sys.argv[1:]))
"""


@pytest.mark.parametrize("command", [
    ["export", "--scene", "cornell", "--effect", "rays", "--size", "8x8", "--out", "{out}"],
    ["run", "--scene", "cornell", "--effect", "ao", "--method", "hbao", "--size", "8x8", "--spp", "4",
     "--warmup", "0", "--frames", "1", "--out", "{out}"],
    ["reference", "--scene", "cornell", "--effect", "ao", "--size", "8x8", "--spp", "4", "--out", "{out}.exr"],
], ids=lambda c: c[0])
def test_ctrl_c_while_mitsuba_starts_is_interrupted_130_and_leaves_nothing(tmp_path, command):
    out = str(tmp_path / "q")
    p = subprocess.run([sys.executable, "-c", SIGINT_IN_DRJIT_START, *[a.format(out=out) for a in command]], cwd=ROOT,
                       capture_output=True, text=True, timeout=300,
                       env={**os.environ, "LDBENCH_CACHE": str(tmp_path / "cache")})
    # `run` may first print its one progress summary line; the last line says why it stopped, and no traceback.
    lines = p.stderr.strip().splitlines()
    assert (p.returncode, lines[-1:], len(lines) <= 2) == (130, ["ldbench: interrupted"], True), p.stderr[-3000:]
    assert list(tmp_path.iterdir()) == [] or [x.name for x in tmp_path.iterdir()] == ["cache"], \
        list(tmp_path.iterdir())
    assert not list(tmp_path.glob("q*")) and not list(tmp_path.glob(".q*"))  # no output, partial folder or lock


def test_deferred_interrupt_raises_after_the_block_and_at_once_on_a_second(monkeypatch):
    from ldbench.core.signals import deferred_interrupt

    done = []
    with pytest.raises(KeyboardInterrupt):
        with deferred_interrupt():
            os.kill(os.getpid(), signal.SIGINT)
            done.append("the block finished")
    assert done and signal.getsignal(signal.SIGINT) is signal.default_int_handler
    with pytest.raises(KeyboardInterrupt):
        with deferred_interrupt():
            os.kill(os.getpid(), signal.SIGINT)
            os.kill(os.getpid(), signal.SIGINT)  # the user insists
            done.append("not reached")
    assert done == ["the block finished"] and signal.getsignal(signal.SIGINT) is signal.default_int_handler


# An export into Q whose process is SIGKILLed at one step: after writing every file into its partial folder,
# or in its commit between moving the previous question aside and moving the new one in.
KILLED_EXPORT = """
import os, signal, sys
from pathlib import Path
from ldbench.core.effects import Effect
from ldbench.harness import export, rundir
from ldbench.harness.score import Question

step, out = sys.argv[1], Path(sys.argv[2])
if step == "written":
    write = export._write_question
    def _write_then_die(q, scene, tmp):
        write(q, scene, tmp)
        os.kill(os.getpid(), signal.SIGKILL)
    export._write_question = _write_then_die
else:
    rename = os.rename
    def _rename_then_die(a, b):
        rename(a, b)
        if os.path.abspath(a) == os.path.abspath(out):  # the previous question aside, the new one not in
            os.kill(os.getpid(), signal.SIGKILL)
    rundir.os.rename = _rename_then_die
export.export_question(Question("cornell", Effect("ao", d_max=0.25), 8, 8, spp=1, seed=7), out)
"""


@pytest.mark.parametrize("step", ["written", "commit"])
def test_export_killed_midway_keeps_the_previous_question(tmp_path, step):
    """SIGKILL after the new files are written, or inside the commit: the previous question is intact (or,
    killed inside the commit, moved aside and put back by the next export), ``score --from`` never reads the
    half-made or moved-aside one as a question, and the next export replaces it whole."""
    from ldbench.core.effects import Effect
    from ldbench.harness.export import export_question
    from ldbench.harness.score import Question, items_from_folder

    q = tmp_path / "qs" / "q"
    export_question(Question("cornell", Effect("ao", d_max=0.5), 8, 8, spp=1), q)
    np_answer = q.parent / "answer"  # an answered copy beside it: what score --from must find, and only that
    export_question(Question("cornell", Effect("ao", d_max=0.5), 8, 8, spp=1), np_answer)
    (np_answer / "answer.npy").write_bytes(b"")
    first = (q / "question.json").read_text()
    p = subprocess.run([sys.executable, "-c", KILLED_EXPORT, step, str(q)], cwd=ROOT, capture_output=True,
                       text=True, timeout=300)
    assert p.returncode == -signal.SIGKILL, p.stderr[-3000:]
    left = sorted(x.name for x in q.parent.iterdir())
    if step == "written":
        assert (q / "question.json").read_text() == first  # untouched
        assert [n for n in left if n.startswith(".q.partial-")], left
    else:
        assert not q.exists() and [n for n in left if n.startswith(".q.old-")], left
    stale = [d for d in q.parent.glob(".q.*") if d.is_dir()]  # the killed export's, each with a question.json
    for d in stale:
        (d / "answer.npy").write_bytes(b"")  # answered even: still no question of its own
    assert [Path(a.path).parent.name for _, a in items_from_folder(q.parent)] == ["answer"]
    for d in stale:
        (d / "answer.npy").unlink()
    again = export_question(Question("cornell", Effect("direct"), 8, 8, spp=1), q)  # sweeps, replaces
    assert json.loads((again / "question.json").read_text())["effect"]["effect"] == "direct"
    assert sorted(x.name for x in q.parent.iterdir()) == ["answer", "q"]
