"""``ldbench history plot`` writes index.html: one offline page of every machine's benchmarks over
commits, its plots linked relatively, the change points listed; ``--no-html`` skips it."""
import re
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

from ldbench.harness import history as H
from ldbench.harness import records as R
from ldbench.reports import history_plots as HP
from ldbench.harness.cli import main
from test_history import GPU, LLVMPIPE, _write_run


class _Links(HTMLParser):
    def __init__(self):
        super().__init__()
        self.refs, self.cards = [], 0

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        for k in ("src", "href"):
            if k in a:
                self.refs.append(a[k])
        if tag == "div" and "card" in (a.get("class") or ""):
            self.cards += 1


def _history(tmp_path, days=16, step_day=9):
    hist = tmp_path / "hist"
    for day in range(1, days + 1):
        ms = 20.0 if day >= step_day else 10.0
        for machine, tag in ((GPU, "g"), (LLVMPIPE, "c")):
            d = _write_run(tmp_path / f"{tag}{day}", f"{tag}-{day:02d}", day=day, ms=ms, machine=machine,
                           psnr=30.0 + 0.03 * np.sin(day), seed=day)
            H.add_run(d, hist)
    return hist


def test_index_html_lists_every_benchmark_of_every_machine_offline(tmp_path, capsys):
    hist = _history(tmp_path)
    out = tmp_path / "site"
    assert main(["history", "plot", "--history-dir", str(hist), "--out", str(out)]) == 0
    assert "index.html" in capsys.readouterr().out
    page = (out / "index.html").read_text(encoding="utf-8")
    p = _Links()
    p.feed(page)
    assert p.cards == 4  # 2 benchmarks x 2 machines
    for key in (R.machine_key(GPU), R.machine_key(LLVMPIPE)):
        assert f'id="{key}"' in page
    pngs = [r for r in p.refs if r.endswith(".png")]
    assert len(set(pngs)) == 4
    for ref in p.refs:  # every link is relative and resolves inside the output folder
        assert not re.match(r"^[a-z]+://|^/", ref), ref
        assert (out / ref).is_file(), ref
    assert "http" not in page  # no scripts, styles or fonts from elsewhere
    assert "cornell · ldm-ao" in page and "16 run(s)" in page and "0000010" in page  # latest commit (day 16)
    # the step on day 9 is a change point of both benchmarks on both machines
    assert page.count("change(s)</span>") == 4
    rows = re.findall(r"<tr><td>.*?</tr>", page)
    assert len(rows) == 4 and all("total_ms" in r for r in rows)
    changes = [float(m) for r in rows for m in re.findall(r"<td>\+([\d.]+)%</td>", r)]
    assert len(changes) == 4 and all(90 < c < 110 for c in changes), changes  # 10 ms -> 20 ms


def test_no_html_flag_and_a_page_without_change_points(tmp_path, capsys):
    hist = _history(tmp_path, days=6, step_day=99)
    out = tmp_path / "site"
    assert main(["history", "plot", "--history-dir", str(hist), "--out", str(out), "--no-html"]) == 0
    assert not (out / "index.html").exists() and (out / "changes.md").is_file()
    res = HP.plot_history(hist, out, machine=R.machine_key(GPU))
    page = Path(res["html"]).read_text(encoding="utf-8")
    assert "No change points." in page and "change(s)</span>" not in page
    assert R.machine_key(LLVMPIPE) not in page and page.count('class="card"') == 2


@pytest.mark.parametrize("name", ["changes.md", "index.html", "png"])
def test_plot_replaces_its_own_files_and_never_a_users(tmp_path, capsys, name):
    """A second ``history plot`` into the same --out replaces what the first wrote; a file of the user's with
    one of its names (changes.md, index.html, a benchmark's PNG) is refused in one line and left as it was."""
    hist = _history(tmp_path, days=6, step_day=3)
    out = tmp_path / "site"
    args = ["history", "plot", "--history-dir", str(hist), "--out", str(out)]
    assert main(args) == 0 and main(args) == 0  # its own files, replaced
    capsys.readouterr()
    target = next(out.rglob("*.png")) if name == "png" else out / name
    target.write_bytes(b"my own notes\n")
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "ldbench did not write it" in err and str(target) in err, err
    assert target.read_bytes() == b"my own notes\n"
