"""The command line explains itself: every option of every sub-command has help text, every help page
points to the exit codes, an unknown suite lists the bundled ones, -v/-q set what reaches stderr, an
ad-hoc AO run gets a finite d_max (said on stderr), and `ldbench scenes` prints whole sentences."""
import argparse
import os
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from ldbench.harness import records as R
from ldbench.harness.cli import build_parser, main
from ldbench.harness.resources import bundled_suites

ROOT = Path(__file__).resolve().parents[1]


def _parsers(p, path=("ldbench",)):
    yield path, p
    for a in p._actions:
        if isinstance(a, argparse._SubParsersAction):
            for name, sub in a.choices.items():
                yield from _parsers(sub, (*path, name))


def test_every_option_of_every_command_has_help_text():
    missing = []
    for path, p in _parsers(build_parser()):
        for a in p._actions:
            if isinstance(a, (argparse._HelpAction, argparse._SubParsersAction)):
                continue
            if not (a.help and a.help.strip() and a.help != argparse.SUPPRESS):
                missing.append(f"{' '.join(path)} {'/'.join(a.option_strings) or a.dest}")
    assert not missing, "options without help text: " + ", ".join(missing)


@pytest.mark.parametrize("argv", [[], ["run"], ["compare"], ["history"], ["reference"], ["scenes"]])
def test_help_pages_point_to_the_exit_codes(argv, capsys):
    with pytest.raises(SystemExit) as e:
        main([*argv, "--help"])
    assert e.value.code == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "docs/reference/cli.md" in out and "Exit status: 0" in out
    if argv == ["run"]:
        assert "bundled suite by name" in out and "default" in out and "nightly" in out
        assert "5% of the scene's largest bounding-box extent" in out  # the ad-hoc ao default


def test_unknown_suite_lists_the_bundled_ones(capsys):
    assert main(["run", "nosuchsuite"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("ldbench: error: ") and "nosuchsuite" in err
    assert all(name in err for name in bundled_suites())


def _run(tmp_path, *extra, env=None):
    out = tmp_path / "run"
    p = subprocess.run([sys.executable, "-m", "ldbench.harness.cli", *extra, "run", "--scene", "cornell", "--method",
                        "hbao", "--effect", "ao", "--size", "16x16", "--spp", "2", "--frames", "1", "--warmup",
                        "0", "--no-report", "--out", str(out)], cwd=ROOT, capture_output=True, text=True,
                       timeout=300, env={**os.environ, **(env or {})})
    return p, out


def test_adhoc_ao_gets_a_finite_d_max_said_on_stderr_and_no_progress_bar_off_a_terminal(tmp_path):
    p, out = _run(tmp_path)
    assert p.returncode == 0, p.stderr
    lines = [l for l in p.stderr.splitlines() if "d_max" in l]
    assert lines == ["ldbench: warning: ao without --d-max: d_max = 0.1 (5% of the scene's largest "
                     "bounding-box extent 2)"], p.stderr
    assert "\r" not in p.stderr and "it/s" not in p.stderr  # stderr is a pipe: no tqdm bar
    assert R.effect_d_max(R.read_results(out).iloc[0]) == pytest.approx(0.1)
    assert "hbao" in p.stdout and "wrote" in p.stdout  # the results table stays on stdout
    p, _ = _run(tmp_path, "-qq")
    assert p.returncode == 0 and "d_max" not in p.stderr, p.stderr


def test_given_d_max_and_suites_are_left_alone(tmp_path, capsys):
    from ldbench.harness.cli import suite_from_args

    args = build_parser().parse_args(["run", "--scene", "cornell", "--method", "hbao", "--effect", "ao",
                                      "--d-max", "inf"])
    (job,) = suite_from_args(args).jobs
    assert job.effect.d_max == float("inf")
    args = build_parser().parse_args(["run", "suites/aalund2015-ao-ci.toml"])
    ds = {j.effect.d_max for j in suite_from_args(args).jobs if j.effect.name == "ao"}
    assert float("inf") in ds  # the suite's own values, not the default
    assert "d_max" not in capsys.readouterr().err


def test_registered_d_max_wins_over_the_fraction(monkeypatch):
    import dataclasses

    from ldbench.core import scene_registry, scenes

    reg = dict(scene_registry.registry())
    name = next(iter(reg))
    reg[name] = dataclasses.replace(reg[name], d_max=2.5)
    monkeypatch.setattr(scene_registry, "registry", lambda: reg)
    assert scenes.default_d_max(name) == (2.5, f"registered for scene {name!r}")
    assert scenes.default_d_max("atrium")[0] == pytest.approx(1.5)  # 5 % of 30 m, as the AO suites use


def test_verbosity_flags_before_and_after_the_command(capsys):
    p = build_parser()
    assert p.parse_args(["-v", "scenes"]).verbose == 1 and p.parse_args(["scenes", "-qq"]).quiet == 2
    assert p.parse_args(["scenes"]).verbose == 0


def test_scene_descriptions_are_whole_sentences(capsys):
    assert main(["scenes"]) == 0
    out = capsys.readouterr().out
    city = next(l for l in out.splitlines() if l.strip().startswith("city "))
    assert city.rstrip().endswith("sets the size.") and "Rungholt" in city and "``" not in city
    from ldbench.core.scenes import doc_summary, list_scenes

    assert all(s["description"].endswith((".", ")")) for s in list_scenes())
    assert doc_summary("One (Fig. 2) thing\nwrapped here. Second sentence.\n\nMore.") == \
        "One (Fig. 2) thing wrapped here."


@pytest.mark.parametrize("verbose,quiet,shown", [(0, 0, ["info", "warning", "error"]),
                                                 (1, 0, ["debug", "info", "warning", "error"]),
                                                 (0, 1, ["warning", "error"]), (0, 2, ["error"])])
def test_log_levels_reach_stderr_as_asked(verbose, quiet, shown, capsys):
    import logging

    from ldbench.harness.cli import setup_logging

    setup_logging(verbose, quiet)
    log = logging.getLogger("ldbench.harness.runner")
    for level in ("debug", "info", "warning", "error"):
        getattr(log, level)(f"a {level} message")
    captured = capsys.readouterr()
    assert captured.out == ""
    got = [l.split("a ")[-1].split()[0] for l in captured.err.splitlines()]
    assert got == shown
    if "info" in shown:
        assert "ldbench: a info message" in captured.err
    assert "ldbench: warning: a warning message" in captured.err or "warning" not in shown
    setup_logging()


def test_module_warnings_are_prefixed_under_python_dash_m(tmp_path):
    # `python -m ldbench.harness.cli` runs cli.py as __main__: the runner's warnings (an ignored emitter of an XML
    # scene) must still reach the handler and read "ldbench: warning: ...", as -q/-qq must still apply.
    xml = tmp_path / "s.xml"
    xml.write_text("""<scene version="3.0.0">
<sensor type="perspective"><float name="fov" value="45"/>
<transform name="to_world"><lookat origin="0, 0.5, 5" target="0, 0, 0" up="0, 1, 0"/></transform></sensor>
<shape type="cube"><bsdf type="diffuse"/></shape>
<emitter type="point"><point name="position" x="0" y="3" z="3"/><rgb name="intensity" value="10"/></emitter>
<emitter type="constant"><rgb name="radiance" value="1"/></emitter>
</scene>
""")
    args = [sys.executable, "-m", "ldbench.harness.cli", "run", "--scene", str(xml), "--method", "direct-raster",
            "--effect", "direct", "--size", "16x16", "--spp", "1", "--frames", "1", "--warmup", "0",
            "--no-report", "--out", str(tmp_path / "run")]
    p = subprocess.run(args, cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    lines = [l for l in p.stderr.splitlines() if "ignored" in l]
    assert lines and all(l.startswith("ldbench: warning: ") for l in lines), p.stderr
    p = subprocess.run(args[:3] + ["-qq"] + args[3:-1] + [str(tmp_path / "run2")], cwd=ROOT,
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 0 and "ignored" not in p.stderr, p.stderr


def test_every_docs_section_a_help_text_cites_exists():
    """A help text that sends the reader to ``docs/X.md, 'Section'`` names a file and a heading that exist."""
    import re

    cited = []
    for path, p in _parsers(build_parser()):
        texts = [p.description or "", p.epilog or "", *(a.help or "" for a in p._actions)]
        for t in texts:
            for doc, section in re.findall(r"(docs/[\w/.-]+\.md)(?:, ['\"]([^'\"]+)['\"])?", t):
                cited.append((" ".join(path), doc, section))
    assert cited, "no help text cites the docs"
    for where, doc, section in cited:
        f = ROOT / doc
        assert f.is_file(), f"{where}: {doc} does not exist"
        if section:
            heads = [l.lstrip("#").strip() for l in f.read_text(encoding="utf-8").splitlines() if l.startswith("#")]
            assert any(h.startswith(section) or section in h for h in heads), f"{where}: {doc} has no section {section!r}"
