"""Every paper reproduction in one run, and the one results page generated from it.

Usage, from the project root with ldbench importable::

    python scripts/gpu/reproduce_all.py run OUT [--scale paper] [--budget SECONDS] [--mirror DIR] [KEY ...]
    python scripts/gpu/reproduce_all.py page OUT [OUT ...] > docs/results/verdicts-<device>.md

``run`` fetches the real scenes from ``--mirror`` (a scene mirror, see ``ldbench scenes fetch --from``), then
runs ``ldbench reproduce KEY --scale SCALE`` for every registered entry (or the KEYs given) into ``OUT/KEY``,
one after another, each under what is left of ``--budget``; an entry that does not fit is named in
``OUT/entries.json`` as not run. ``page`` writes Markdown from ``OUT`` alone: the command, date, commit,
driver and device, a table of every entry's verdict counts, and each claim with its verdict, our number, the
published one and the reason for every failure, premises apart from verdicts.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

from ldbench.reports import reproduce as R

#: The page's columns: (heading, the verdict reproduce writes, matched at its start: NOT_AT_SCALE names a scale).
VERDICTS = (("holds", R.HOLDS), ("fails", R.FAILS), ("inconclusive", R.INCONCLUSIVE),
            ("not measurable here", R.NOT_MEASURABLE), ("not measured", R.NOT_MEASURED),
            ("not at this scale", R.NOT_AT_SCALE.split("{")[0]), ("set-up unmet", R.SETUP_UNMET))


def verdict_counts(claims) -> list[int]:
    """How many of ``claims`` fall under each column of :data:`VERDICTS`; a verdict none names is an error
    (a new verdict must get a column, not vanish from the table)."""
    n = [0] * len(VERDICTS)
    for c in claims:
        v = str(c.get("verdict", ""))
        i = next((i for i, (_, words) in enumerate(VERDICTS) if v.startswith(words)), None)
        if i is None:
            raise ValueError(f"verdict {v!r} of claim {c.get('text')!r} has no column on the page")
        n[i] += 1
    return n


def _ldbench(*args: str) -> list[str]:
    return [sys.executable, "-m", "ldbench.harness.cli", *args]


def entry_keys() -> list[str]:
    return list(R.registry())


def run(out: Path, keys: list[str], scale: str, budget: float, mirror: str | None) -> int:
    out.mkdir(parents=True, exist_ok=True)
    if mirror:
        for scene in ("sponza", "sibenik", "dragon"):
            subprocess.run(_ldbench("scenes", "fetch", scene, "--from", mirror), capture_output=True, text=True)
    t_start = time.monotonic()
    entries = []
    for key in keys:
        left = budget - (time.monotonic() - t_start)
        rec = {"key": key, "scale": scale}
        if left < 5:
            rec.update(status="not run", reason="did not fit in the time budget")
            entries.append(rec)
            continue
        t0 = time.monotonic()
        cmd = _ldbench("reproduce", key, "--scale", scale, "--out", str(out / key), "--no-progress")
        try:
            p = subprocess.run(cmd, capture_output=True, text=True, timeout=left)
            rec.update(rc=p.returncode, status="ran" if p.returncode in (0, 1) else "error",
                       reason="" if p.returncode in (0, 1) else (p.stderr.strip().splitlines() or ["?"])[-1])
            (out / f"{key}.log").write_text(p.stdout + p.stderr)
        except subprocess.TimeoutExpired:
            rec.update(status="not run", reason=f"stopped at the time budget after {left:.0f} s")
        rec["seconds"] = round(time.monotonic() - t0, 1)
        entries.append(rec)
        print(f"{key}: {rec['status']} in {rec['seconds']} s {rec['reason']}", file=sys.stderr)
    meta = {"command": " ".join([Path(sys.argv[0]).as_posix(), *sys.argv[1:]]),
            "started": time.strftime("%Y-%m-%d %H:%M:%S %Z"), "budget_s": budget, "entries": entries}
    (out / "entries.json").write_text(json.dumps(meta, indent=1))
    return 0


def _cell(s) -> str:
    return str(s if s not in (None, "") else "–").replace("|", "\\|").replace("\n", " ")


def _device_name(doc: dict) -> str:
    """The GPU's name from a reproduce.json's ``our_setup`` ("device nvidia, ..., GPU NAME, 800x800, ...")."""
    parts = [x.strip() for x in str(doc.get("our_setup", "")).split(",")]
    return next((x[len("GPU "):] for x in parts if x.startswith("GPU ")), "an unnamed device")


def page(outs: list[Path], notes: tuple[str, ...] = ()) -> str:
    """The page of one run, or of several (a later run's entries replace an earlier one's), in the
    registry's order; ``notes``: lines printed under the run's header (what the rows cannot say)."""
    metas = [json.loads((out / "entries.json").read_text()) for out in outs]
    found = {e["key"]: (out, e) for out, m in zip(outs, metas) for e in m["entries"]}
    order = [k for k in entry_keys() if k in found] + [k for k in found if k not in entry_keys()]
    meta = {"entries": [found[k][1] for k in order]}
    docs = {k: json.loads((found[k][0] / k / "reproduce.json").read_text())
            for k in order if (found[k][0] / k / "reproduce.json").is_file()}
    first = next(iter(docs.values()), {})
    lines = ["<!-- generated by scripts/gpu/reproduce_all.py page; do not edit -->",
             f"# Paper reproductions on {_device_name(first)}: the verdicts of one run", "",
             *[f"- command: `{m['command']}`, started {m['started']}, budget {m['budget_s']:.0f} s" for m in metas],
             f"- device: {first.get('our_setup', 'unknown')}",
             f"- run: {first.get('run', 'unknown')}", *[f"- note: {n}" for n in notes], "",
             "| entry | status | s | " + " | ".join(h for h, _ in VERDICTS) + " |",
             "|---|---|---|" + "---|" * len(VERDICTS)]
    for e in meta["entries"]:
        d = docs.get(e["key"])
        n = verdict_counts((d or {}).get("claims", []))
        lines.append(f"| {e['key']} | {e['status']}{': ' + _cell(e['reason']) if e.get('reason') else ''} | "
                     f"{e.get('seconds', '–')} | " + " | ".join(map(str, n)) + " |")
    not_run = [e["key"] for e in meta["entries"] if e["status"] != "ran"]
    if not_run:
        lines += ["", "Not run or stopped: " + ", ".join(not_run) + " (the status column says why)."]
    for key, d in docs.items():
        lines += ["", f"## {key}: {d.get('title', '')}", "",
                  f"{d.get('paper', '')} {d.get('source', '')}. Published: {d.get('published_setup', '')}. "
                  f"Ours: {d.get('our_setup', '')}. {d.get('run', '')}.", "",
                  "| claim | verdict | ours | published | reason |", "|---|---|---|---|---|"]
        for c in d.get("claims", []):
            lines.append(f"| {_cell(c.get('text'))} | {_cell(c.get('verdict'))} | {_cell(c.get('ours'))} | "
                         f"{_cell(c.get('published'))} | {_cell(c.get('reason'))} |")
        premises = d.get("premises") or []
        if premises:
            lines += ["", "Premises (true by construction of the set-up; not verdicts):", ""]
            lines += [f"- {_cell(p.get('text') if isinstance(p, dict) else p)}"
                      + (f": {_cell(p.get('ours'))}" if isinstance(p, dict) and p.get("ours") else "")
                      for p in premises]
        if d.get("errors"):
            lines += ["", "Errors: " + "; ".join(_cell(x) for x in d["errors"])]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("out", type=Path)
    r.add_argument("keys", nargs="*")
    r.add_argument("--scale", default="paper")
    r.add_argument("--budget", type=float, default=1200.0, help="seconds for all entries together")
    r.add_argument("--mirror", help="a scene mirror holding sponza, sibenik, dragon")
    pg = sub.add_parser("page")
    pg.add_argument("out", type=Path, nargs="+", help="one run's OUT, or several (a later one's entries win)")
    pg.add_argument("--note", action="append", default=[], help="a line under the header (repeatable)")
    a = ap.parse_args(argv)
    if a.cmd == "run":
        return run(a.out, a.keys or entry_keys(), a.scale, a.budget, a.mirror)
    sys.stdout.write(page(a.out, tuple(a.note)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
