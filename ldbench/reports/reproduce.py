"""``ldbench reproduce``: one paper table or figure, our numbers beside the published ones.

This module is the engine (the :class:`Claim` and :class:`Reproduction` records, row matching,
verdicts, printing, the command); the papers' numbers are data in :mod:`ldbench.reports.reproductions`, one
folder per paper table, collected by :func:`registry`. An entry is data:

* where the numbers come from (paper key, figure/table, the GPU and resolution the paper used),
* the suite that reproduces it: ``suite.toml`` in the table's folder (:func:`suite_file`), bundled under the
  entry's key (``ldbench run aalund2015-fig8``),
* ``rows``: a list of dicts, one per published row (or one per row of ours that a claim needs), each
  with a ``match`` that selects our result row (scene, method, effect, size, params, scene_params;
  any other key is a parameter of the effect, e.g. d_max, falloff) and the published values under the
  keys of :data:`QUANTITIES`,
* ``claims``: the paper's statements as comparisons between rows (:class:`Claim`), each with a verdict
  on our numbers: ``holds`` / ``does not hold on this machine`` / ``not measured`` (a row is missing or
  failed) / ``inconclusive`` (the noise straddles the bound) / for times on a CPU, ``not measurable
  here`` (docs/reference/reports.md, "Timing verdicts"); each claim's verdict rule and the derivation of its
  window from the paper's words (``Claim.why``) are printed with the table (docs/reference/claims.md),
* ``scales``: suite overrides for ``--scale ci`` (tiny, for CI on llvmpipe) and ``--scale paper`` (the
  suite as written). A scale's parameter overrides are applied to the rows' ``match`` too, so the same
  rows find their counterparts at every scale.

Adding a paper table is one folder, ``ldbench/reports/reproductions/<paper>/<table>/``: its ``__init__.py``
defines ``REPRODUCTION`` (one :class:`Reproduction`) and ``suite.toml`` beside it is the suite; the paper's
``__init__.py`` holds what its tables share. :func:`registry` finds it (no engine change). The steps, the
quantities a row may give and the timing verdict rules (and the measurements behind them) are in
docs/reference/reports.md, "Adding a table", and docs/how-to/reproduce-a-paper-table.md.
"""
from __future__ import annotations

import dataclasses
import importlib
import json
import math
import pkgutil
import time
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType
from typing import Callable

from ldbench.core import scene_registry
from ldbench.core.errors import Interrupted, LdbenchError
from ldbench.core.files import atomic_write_text
from ldbench.core.scenes import registered_needed
from ldbench.harness.executors import run_jobs
from ldbench.harness.records import effect_d_max, effect_param, read_results, structure_bytes
from ldbench.harness.resources import TABLE_SUITE, table_key
from ldbench.harness.rundir import is_run_dir
from ldbench.harness.suite import load_suite, parse_size
from ldbench.methods.base import get_method

from . import reproductions
from .figures.table import as_dict
from .labels import fmt_value

# One lazy import, on purpose: .report (in reproduce(), only when the HTML report is written) loads scipy
# through its figures; the engine, `ldbench reproduce --list` and the entry modules stay without it.


#: quantity → (our column, unit, higher is better, label)
QUANTITIES = {
    "time_ms": ("total_ms", "ms", False, "time"),
    "memory_mb": ("memory_bytes", "MB", False, "memory"),
    "structure_mb": ("structure_bytes", "MB", False, "structure memory"),
    "psnr": ("psnr", "dB", True, "PSNR"),
    "ssim": ("ssim", "", True, "SSIM"),
    "flip": ("flip", "", False, "FLIP"),
    "relmse": ("relmse", "", False, "relMSE"),
    "rays_per_s": ("rays_per_s", "rays/s", True, "rays/s"),
    "hit_agreement": ("hit_agreement", "", True, "hit agreement"),
    "dist_err_p95": ("dist_err_p95", "", False, "p95 distance error / diagonal"),
    "oracle_rays_per_s": ("oracle_rays_per_s", "rays/s", True, "Mitsuba oracle rays/s"),
}
FAMILIES = ("stage:", "counter:")


def quantity(q: str) -> tuple:
    """(column, unit, higher is better, label) of a quantity: one of :data:`QUANTITIES`, ``stage:NAME``
    or ``counter:NAME`` (module docstring)."""
    if q in QUANTITIES:
        return QUANTITIES[q]
    if q.startswith("stage:") and q[6:]:
        return "stage_ms", "ms", False, f"{q[6:]} stage time"
    if q.startswith("counter:") and q[8:]:
        return "counters", "", True, q[8:]
    raise LdbenchError(f"unknown quantity {q!r} (known: {', '.join(QUANTITIES)}, stage:NAME, counter:NAME)")


def row_quantities(row: dict) -> list:
    """The quantities a published row gives: keys of :data:`QUANTITIES` in that order, then its
    ``stage:`` and ``counter:`` keys in their own order."""
    return [q for q in QUANTITIES if q in row] + [k for k in row if k.startswith(FAMILIES)]

HOLDS = "holds"
FAILS = "does not hold on this machine"
NOT_MEASURED = "not measured"
INCONCLUSIVE = "inconclusive (difference within the timing noise)"
NOT_MEASURABLE = "not measurable here"  # a time claim on cpu-software (wall clock on shared cores)
NOT_AT_SCALE = "not comparable at scale {scale}"  # a claim whose rows only mean something at other scales
PREMISE = "premise (no verdict)"  # a statement our set-up decides by construction: printed, never judged
SETUP_UNMET = "not judged: its set-up check does not hold"  # Claim.requires read anything but HOLDS

CPU_SOFTWARE = "cpu-software"
TIME_QUANTITIES = ("time_ms", "rays_per_s")  # with every stage:NAME: the quantities that get the timing rules


@dataclass(frozen=True)
class Claim:
    """A statement of the paper as a comparison between two rows (by ``id``).

    ``kind``:

    * ``"less"`` / ``"greater"``: row ``a``'s value is below / above row ``b``'s for every quantity;
    * ``"better"``: ``a`` beats ``b`` on every quantity (lower time/memory/FLIP/relMSE, higher PSNR/SSIM);
    * ``"ratio"``: a / b of every quantity lies within ``ratio`` = (lo, hi);
    * ``"within"``: a's value of every quantity lies within ``ratio`` = (lo, hi) (b is not used; give a);
    * ``"gap"``: a / b exceeds c / d for every quantity (rows ``c`` and ``d``): "the gap grows".

    ``b_quantity``: compare a's quantity with this quantity of b (e.g. two stages of one row, a = b);
    default: the same quantity on both sides.

    ``why``: how the window (``ratio``) follows from the paper's words and numbers, or why a direction
    alone is the claim; printed with the verdict rule beside the table. ``scales``: the scales at which
    the claim's rows are comparable (empty: all); at another scale the verdict is
    :data:`NOT_AT_SCALE`, e.g. when the ci scale's scene sizes invert the paper's ratio.

    ``ours``: a claim that is not the paper's (the paper's comparison made against a baseline of ours, or a
    control of ours beside a paper claim); printed apart from the paper's claims, labelled.

    ``requires``: the text of another claim of the entry that checks this claim's set-up (e.g. that two rows
    compare like with like); unless that claim holds, this one reads :data:`SETUP_UNMET` instead of a verdict.

    As a *premise* (:attr:`Reproduction.premises`) the same record states what our set-up decides by
    construction: our numbers are printed beside the published ones, ``why`` says why they cannot
    contradict the paper, and no verdict is given.
    """

    text: str
    a: str
    b: str
    quantities: tuple = ("time_ms",)
    kind: str = "less"
    ratio: tuple | None = None
    where: str = ""  # where the paper says it (figure, section)
    published: str = ""  # the published evidence when not a pair of numbers (e.g. "images only")
    c: str = ""  # kind "gap": the second pair
    d: str = ""
    b_quantity: str = ""
    why: str = ""
    scales: tuple = ()
    # why it fails or is inconclusive on the machine measured (printed beside such a verdict); a callable takes
    # value(row id, quantity) -> our number and returns the text, so that it quotes the run's own measurement
    reason: str | Callable[[Callable[[str, str], float]], str] = ""
    ours: bool = False  # not the paper's statement (e.g. the paper's comparison against our own baseline)
    requires: str = ""  # the text of a claim of this entry that checks this one's set-up: judged only if it holds


@dataclass(frozen=True)
class Reproduction:
    key: str
    paper: str
    title: str
    source: str  # figure / table and section in the paper
    hardware: str  # the paper's GPU
    resolution: str  # the paper's image size
    paper_scene: str
    rows: tuple  # dicts, see the module docstring
    claims: tuple = ()
    scales: dict = field(default_factory=dict)
    notes: tuple = ()
    #: statements of the paper that our set-up decides by construction (:class:`Claim` records whose ``why``
    #: says why): printed apart from the claims with our numbers, never a verdict
    premises: tuple = ()
    #: the table's folder, which holds its ``suite.toml`` (:func:`suite_file`): filled in by :func:`registry`
    #: from where the entry's module lies, never written by hand (None: an entry made outside the registry)
    folder: Path | None = None


def registry() -> dict[str, Reproduction]:
    """{key: entry} of every paper table in :mod:`ldbench.reports.reproductions`: each folder
    ``<paper>/<table>/`` (found with pkgutil; names starting with ``_`` are skipped) whose ``__init__.py``
    defines ``REPRODUCTION`` and which holds the table's ``suite.toml``. The entry's key must be the folder's
    (:func:`~ldbench.harness.resources.table_key`: ``aalund2015/fig8_real`` is ``aalund2015-fig8-real``), the
    name under which ``ldbench run`` finds the same suite; :attr:`Reproduction.folder` is set here.

    Papers come in name order, a paper's tables in the order of its ``TABLES`` (the order ``--list`` has
    always shown), then any table it does not name, by name: a new table is one new folder."""
    global _REGISTRY
    if _REGISTRY is None:
        found: dict[str, Reproduction] = {}
        for paper in sorted(pkgutil.iter_modules(reproductions.__path__), key=lambda m: m.name):
            if paper.name.startswith("_"):
                continue
            name = f"{reproductions.__name__}.{paper.name}"
            if not paper.ispkg:
                raise TypeError(f"{name} is a module: a paper is a folder with one folder per table, each with an "
                                f"__init__.py defining REPRODUCTION and its {TABLE_SUITE}")
            pkg = importlib.import_module(name)
            for table in _tables(pkg):
                m = importlib.import_module(f"{name}.{table}")
                e = getattr(m, "REPRODUCTION", None)
                if not isinstance(e, Reproduction):
                    raise TypeError(f"{m.__name__} must define REPRODUCTION, a Reproduction entry")
                key = table_key(paper.name, table)
                if e.key != key:
                    raise ValueError(f"{m.__name__} defines {e.key!r}: a table's key is its folder's, {key!r} "
                                     "(the name ldbench run finds its suite by)")
                folder = Path(m.__path__[0]).resolve()
                if not (folder / TABLE_SUITE).is_file():
                    raise ValueError(f"{m.__name__} has no {TABLE_SUITE} beside it ({folder})")
                found[key] = dataclasses.replace(e, folder=folder)
        _REGISTRY = found
    return _REGISTRY


_REGISTRY: dict | None = None


def _tables(paper: ModuleType) -> list[str]:
    """The table folders (sub-packages) of a paper package: those its ``TABLES`` names, in that order, then
    the others by name. A name in ``TABLES`` without its folder is an error (a table renamed or removed)."""
    names = sorted(m.name for m in pkgutil.iter_modules(paper.__path__) if m.ispkg and not m.name.startswith("_"))
    order = tuple(getattr(paper, "TABLES", ()))
    gone = [t for t in order if t not in names]
    if gone:
        raise ValueError(f"{paper.__name__}.TABLES names {gone[0]!r}, which is not a table folder of it "
                         f"(its tables: {', '.join(names)})")
    return [*order, *(t for t in names if t not in order)]


# --------------------------------------------------------------------------------------------------
# scaling a suite and its rows


def _map(value, override):
    """Apply one override: a dict maps old → new (unlisted values unchanged), anything else replaces."""
    if isinstance(override, dict):
        for k, v in override.items():
            if _same(k, value):
                return v
        return value
    return override


def _same(a, b) -> bool:
    if isinstance(a, str) or isinstance(b, str):
        return str(a) == str(b)
    try:
        fa, fb = float(a), float(b)
    except (TypeError, ValueError):
        return a == b
    if math.isinf(fa) or math.isinf(fb):
        return fa == fb
    return math.isclose(fa, fb, rel_tol=1e-6, abs_tol=1e-9)


def _method(name) -> str:
    """The registered name of a method named by its name or an alias (as given when unknown), so that
    data written with an older name still finds its rows and overrides."""
    try:
        return get_method(str(name)).name
    except Exception:  # noqa: BLE001 - unknown method (an old run): compare names as they are
        return str(name)


def _method_overrides(scale: dict, method) -> dict:
    """A scale's parameter overrides for one method (keys of ``scale["params"]`` may be aliases)."""
    return next((ov for k, ov in scale.get("params", {}).items() if _method(k) == _method(method)), {})


def scale_suite(suite, scale: dict, size: str | None = None):
    """Apply a scale's overrides (size, spp, warmup, frames, method params, scene params) to a suite's
    jobs; duplicates created by the overrides are dropped."""
    jobs, seen = [], set()
    w_h = parse_size(size) if size else (parse_size(scale["size"]) if scale.get("size") else None)
    for j in suite.jobs:
        params = dict(j.params)
        for k, ov in _method_overrides(scale, j.method).items():
            if k in params or not isinstance(ov, dict):
                params[k] = _map(params.get(k), ov)
        sparams = dict(j.scene_params)
        for k, ov in scale.get("scene_params", {}).get(j.scene, {}).items():
            sparams[k] = _map(sparams.get(k), ov)
        try:
            cls = get_method(j.method)
        except LdbenchError:
            cls = None  # unknown methods are rejected by the suite loader already
        if cls is not None:
            cls.Params.from_dict(params, method=j.method)  # an override the method rejects is an error
        nj = dataclasses.replace(
            j, params=tuple(sorted(params.items())), scene_params=tuple(sorted(sparams.items())),
            width=w_h[0] if w_h else j.width, height=w_h[1] if w_h else j.height,
            spp=int(scale.get("spp", j.spp)), warmup=int(scale.get("warmup", j.warmup)),
            frames=int(scale.get("frames", j.frames)))
        key = (nj.scene, nj.scene_params, nj.method, nj.params, nj.effect, nj.width, nj.height)
        if key not in seen:
            seen.add(key)
            jobs.append(nj)
    return dataclasses.replace(suite, jobs=jobs)


def scale_match(match: dict, scale: dict) -> dict:
    m = dict(match)
    if "params" in m:
        ov = _method_overrides(scale, m.get("method"))
        m["params"] = {k: (_map(v, ov[k]) if k in ov else v) for k, v in m["params"].items()}
    if "scene_params" in m:
        ov = scale.get("scene_params", {}).get(m.get("scene"), {})
        m["scene_params"] = {k: (_map(v, ov[k]) if k in ov else v) for k, v in m["scene_params"].items()}
    return m


# --------------------------------------------------------------------------------------------------
# matching our rows


#: Keys of a row's ``match`` that are not effect parameters.
_MATCH_ROW_KEYS = ("scene", "method", "effect", "size", "params", "scene_params")


def _with_defaults(r: dict, match: dict) -> dict:
    """``r`` with the method's defaults for the parameters ``match`` names that ``r`` lacks (a run older
    than the parameter ran with its default, e.g. hbao's ``sampling``)."""
    params = r.get("params")
    have = params if isinstance(params, dict) else {}
    defaults = _defaults(r.get("method"))
    missing = {k: defaults[k] for k in (match.get("params") or {}) if k not in have and k in defaults}
    return {**r, "params": {**have, **missing}} if missing else r


def _defaults(method) -> dict:
    try:
        return get_method(str(method)).Params().to_dict()
    except Exception:  # noqa: BLE001 - unknown method (an old run)
        return {}


def _matches(r, m: dict) -> bool:
    if r.get("status") != "ok":
        return False
    for k in ("scene", "effect"):
        if k in m and str(r.get(k)) != str(m[k]):
            return False
    if "method" in m and _method(r.get("method")) != _method(m["method"]):
        return False
    for k, want in m.items():  # every other key is an effect parameter (d_max, falloff, ...)
        if k not in _MATCH_ROW_KEYS:
            have = effect_d_max(r) if k == "d_max" else effect_param(r, k)
            if have is None or not _same(have, want):
                return False
    if "size" in m and f"{r.get('width')}x{r.get('height')}" != m["size"]:
        return False
    for col, key in (("params", "params"), ("scene_params", "scene_params")):
        want = m.get(key) or {}
        have = r.get(col) if isinstance(r.get(col), dict) else {}
        if col == "params":  # earlier and current parameter names alike (Params.renamed)
            want, have = _current_names(r.get("method"), want), _current_names(r.get("method"), have)
        if any(k not in have or not _same(have[k], v) for k, v in want.items()):
            return False
    return True


def _current_names(method, params: dict) -> dict:
    """``params`` under the method's current (dotted) names; as given when the method or a name is unknown."""
    try:
        return get_method(method).Params.upgrade(params)
    except LdbenchError:
        return params


def find_row(rows: list, match: dict):
    """Our row for a published row: the matching successful row (the largest image when several)."""
    cands = [r for r in rows if _matches(r, match) or _matches(_with_defaults(r, match), match)]
    if not cands:
        return None, 0
    cands.sort(key=lambda r: -(int(r.get("width") or 0) * int(r.get("height") or 0)))
    return cands[0], len(cands)


def _shown_params(r, match) -> dict:
    """The parameters worth printing: those the row was matched on and those off their defaults."""
    try:
        cls = get_method(r["method"]).Params
        defaults = cls().to_dict()
    except Exception:  # noqa: BLE001 - unknown method in an old run: show what we have
        cls, defaults = None, {}
    want = _current_names(r.get("method"), match.get("params") or {})
    full = _current_names(r.get("method"), r["params"])
    shown = {k: v for k, v in full.items() if k in want or (k in defaults and not _same(defaults[k], v))}
    return cls.with_presets(shown, full) if cls is not None else shown


def _float(v):
    try:
        f = float(v)
    except (TypeError, ValueError):
        return None
    return None if math.isnan(f) else f


def _noise(r, q: str = "time_ms"):
    """Timing noise of a row: its interquartile range of frame times (ms), 0 when unknown; for
    ``stage:NAME`` (``stage:a+b``) the stages' IQRs (summed), the frame's when the row has none; for
    ``rays_per_s`` (rays / frame time) the frame's relative IQR of the rate."""
    if q == "rays_per_s":
        rate, t, iqr = _float(r.get("rays_per_s")), _float(r.get("total_ms")), _float(r.get("total_ms_iqr"))
        return rate * iqr / t if None not in (rate, t, iqr) and t > 0 else 0.0
    if q.startswith("stage:") and isinstance(r.get("stage_iqr"), dict):
        vals = [_float(r["stage_iqr"].get(n)) for n in q[6:].split("+")]
        if all(v is not None for v in vals):
            return float(sum(vals))
    return _float(r.get("total_ms_iqr")) or 0.0


def _timed(q: str) -> bool:
    return q in TIME_QUANTITIES or q.startswith("stage:")


def _device(r):
    """A row's device, None when the row does not name one (missing, empty, NaN from a table)."""
    d = r.get("device")
    if d is None or (isinstance(d, float) and math.isnan(d)):
        return None
    d = str(d).strip()
    return d if d and d.lower() not in ("nan", "none") else None


def time_verdict(ra, rb, va: float, vb: float, kind: str = "less", qa: str = "time_ms", qb: str = ""):
    """The verdict two rows' times force on a claim, or None when the comparison stands.

    A row with no ``device``: :data:`NOT_MEASURED` (where its times came from is unknown, so neither
    rule below applies). cpu-software (either row): always :data:`NOT_MEASURABLE`. Frames there are wall
    clock on shared cores: the spread within one job (its frames) misses the spread between jobs, which was
    up to 2.1× between back-to-back runs (6× with two runs at once; docs/reference/reports.md, "Timing verdicts"), so
    no within-run test can tell a difference from the load. GPU (timer queries): :data:`INCONCLUSIVE` when
    ``|va − vb|`` is within the larger noise of the two sides, each side's noise that of its own quantity
    (``qa`` for a, ``qb`` for b, default ``qa``; :func:`_noise`: a stage's own IQR for ``stage:NAME``)
    (order claims; ratio, window and gap claims test their bounds with the noise instead, :func:`_interval`).
    """
    if _device(ra) is None or _device(rb) is None:
        return NOT_MEASURED
    if CPU_SOFTWARE in (_device(ra), _device(rb)):
        return NOT_MEASURABLE
    if kind in ("less", "greater", "better") and abs(va - vb) <= max(_noise(ra, qa), _noise(rb, qb or qa)):
        return INCONCLUSIVE
    return None


def _interval(kind, va, vb, na, nb):
    """(lowest, highest) of a claim's measured value (a / b for ``ratio``, a for ``within``) when a and b
    each move by up to their noise na, nb (GPU: the rows' IQRs of the frame time; 0 for deterministic
    quantities such as memory or PSNR)."""
    if kind == "within":
        return va - na, va + na
    lo_b, hi_b = vb - nb, vb + nb
    if lo_b <= 0:
        return -math.inf, math.inf
    return (va - na) / hi_b, (va + na) / lo_b


def _bound_verdict(window, lo, hi):
    """True when [lo, hi] lies inside the window, False when wholly outside, None when it straddles a
    bound (the noise decides: inconclusive)."""
    w0, w1 = window
    if w0 <= lo and hi <= w1:
        return True
    if hi < w0 or lo > w1:
        return False
    return None


def our_value(r, q: str):
    if r is None:
        return None
    col = quantity(q)[0]
    v = r.get(col)
    if q == "structure_mb" and _float(v) is None and isinstance(r.get("memory"), dict):
        v = structure_bytes(r["memory"])
    if q.startswith(FAMILIES):
        d = as_dict(v) or {}
        names = q.split(":", 1)[1].split("+")
        vals = [_float(d.get(n)) for n in names]
        return None if any(x is None for x in vals) else float(sum(vals))
    try:
        v = float(v)
    except (TypeError, ValueError):
        return None
    if math.isnan(v):
        return None
    return v / 2**20 if q in ("memory_mb", "structure_mb") else v


def _fmt(v, q=None) -> str:
    if v is None:
        return "–"
    unit = quantity(q)[1] if q else ""
    if unit == "rays/s" and abs(v) >= 1e6:  # rates in M or G rays/s
        big = abs(v) >= 1e9
        return f"{v / (1e9 if big else 1e6):.3g} {'G' if big else 'M'} rays/s"
    if q in ("ssim", "flip") or (q == "structure_mb" and abs(v) < 1):
        s = f"{v:.3f}"
    elif q == "relmse":
        s = f"{v:.4f}"
    elif abs(v) >= 100:
        s = f"{v:.1f}"
    else:
        s = f"{v:.3g}" if abs(v) < 1 else f"{v:.2f}"
    return f"{s} {unit}".strip()


def _versus(ours, pub, q) -> str:
    """Ours beside a published value. A time or a rate (measured on another GPU generation) reads as the
    speed-up, "N× faster" or "N× slower" (a ratio such as 0.00217× says the same less plainly); any other
    quantity as ours / published."""
    if ours is None or pub is None or pub == 0:
        return "–"
    if _timed(q) or q == "oracle_rays_per_s":
        if ours <= 0:
            return "–"
        s = ours / pub if quantity(q)[2] else pub / ours  # > 1: ours is faster
        return f"{s:.3g}× faster" if s >= 1 else f"{1 / s:.3g}× slower"
    return f"{ours / pub:.3g}×"


# --------------------------------------------------------------------------------------------------
# evaluation


def _compare(kind, q, a, b, ratio=None):
    hib = quantity(q)[2]
    if kind == "less":
        return a < b
    if kind == "greater":
        return a > b
    if kind == "better":
        return a > b if hib else a < b
    if kind == "ratio":
        return b != 0 and ratio[0] <= a / b <= ratio[1]
    if kind == "gap":  # a, b: the two ratios
        return a > b
    raise LdbenchError(f"unknown claim kind {kind!r}")


def _side(kind, q, va, vb, ratio=None) -> str:
    if va is None or vb is None:
        return "–"
    if kind == "gap":
        return f"{va:.3g}× vs {vb:.3g}×"
    if kind == "ratio":
        return f"{_fmt(va, q)} / {_fmt(vb, q)} = {va / vb:.2f}×" if vb else "–"
    return f"{_fmt(va, q)} vs {_fmt(vb, q)}"


def _bounds(c: Claim) -> str:
    assert c.ratio is not None  # only claims with a window are given
    lo, hi = c.ratio
    q = c.quantities[0]
    if c.kind == "within" and quantity(q)[1] == "rays/s":  # rates in M or G rays/s
        return f"{_fmt(lo, q)} – {'∞' if math.isinf(hi) else _fmt(hi, q)}"
    unit = "×" if c.kind == "ratio" else f" {quantity(c.quantities[0])[1]}".rstrip()
    hi_s = "∞" if math.isinf(hi) else _g(hi)
    return f"{_g(lo)}–{hi_s}{unit}"


def _g(x: float) -> str:
    """A window bound in 3 significant digits, or 4 where 3 would move it by more than 0.25 % (1.005 is not 1)."""
    s = f"{x:.3g}"
    return s if abs(float(s) - x) <= 2.5e-3 * abs(x) else f"{x:.4g}"


#: The verdict rule of each claim kind (printed with every claim; docs/reference/claims.md, "Verdict rules").
KIND_RULES = {
    "less": "holds if a < b",
    "greater": "holds if a > b",
    "better": "holds if a beats b on every quantity",
    "ratio": "holds if a / b lies in the window for every value within the rows' noise; fails if it lies "
             "outside for every such value; inconclusive if the noise straddles a bound",
    "within": "holds if a lies in the window for every value within the row's noise; fails if outside for "
              "every such value; inconclusive if the noise straddles a bound",
    "gap": "holds if a / b exceeds c / d for every value within the rows' noise; fails if it does not exceed it "
           "for any such value; inconclusive if the two ranges overlap",
}
TIMING_RULE = ("T: times are not measurable here on cpu-software (wall clock on shared cores, between-job spread up "
               "to 2.1×, whatever the difference) and not measured on a row with no device; on a GPU the "
               "noise of each side is its row's IQR of that side's quantity (a stage's own IQR for a stage time, the "
               "frame's for a frame time, the frame's relative IQR for a rate), "
               "an order claim within the larger noise is inconclusive")


def rule_text(c: Claim) -> str:
    """The verdict rule and the window's derivation of a claim, as printed beside the table."""
    rule = KIND_RULES.get(c.kind, c.kind)
    if c.kind in ("ratio", "within") and c.ratio:
        rule = rule.replace("the window", f"[{_bounds(c)}]")
    if any(_timed(q) for q in (*c.quantities, c.b_quantity)):
        rule += "; timing rule T"
    why = c.why or ("direction only: the paper states the order, not its size" if c.kind in
                    ("less", "greater", "better", "gap") else "no derivation given")
    out = f"{rule}. Window: {why}" if c.kind in ("ratio", "within") else f"{rule}. {why[0].upper()}{why[1:]}"
    if c.scales:
        out += f". Verdict only at scale {', '.join(c.scales)}"
    if c.requires:
        out += f". Judged only when '{c.requires}' holds"
    return out


class _Unmeasured(LookupError):
    pass


def _reason(c: Claim, found: dict) -> str:
    """The claim's reason; a measured one (a callable) evaluated on our rows, or a line naming what it lacks."""
    if not callable(c.reason):
        return c.reason

    def value(row_id: str, q: str) -> float:
        v = our_value(found.get(row_id), q)
        if v is None or not math.isfinite(v):
            raise _Unmeasured(f"{q} of row {row_id}")
        return v

    try:
        return c.reason(value)
    except _Unmeasured as e:
        return f"not explained: the measurement that would explain it is missing ({e})"


def _judge(c: Claim, found: dict, pub_rows: dict, scale_name: str) -> dict:
    """One claim on our rows (``found``: row id → our row or None): its published and measured sides,
    verdict, rule and reason."""
    ra, rb = found.get(c.a), found.get(c.a if c.kind == "within" else c.b)
    parts, pub_parts, timing = [], [], set()
    verdicts: list[bool | None] = []  # per quantity; None: not measured
    window = c.ratio
    for q in c.quantities:
        qb = c.b_quantity or q
        va, vb = our_value(ra, q), our_value(rb, qb)
        pa, pb = pub_rows.get(c.a, {}).get(q), pub_rows.get(c.b, {}).get(qb)
        timed = [(ra, rb, va, vb)]
        gap_sides = None
        if c.kind == "gap":  # compare a/b with c/d: the sides become the two ratios
            rc, rd = found.get(c.c), found.get(c.d)
            vc, vd = our_value(rc, q), our_value(rd, q)
            timed.append((rc, rd, vc, vd))
            gap_sides = ((ra, rb, va, vb), (rc, rd, vc, vd))
            va = va / vb if None not in (va, vb) and vb else None
            vb = vc / vd if None not in (vc, vd) and vd else None
            pc, pd = pub_rows.get(c.c, {}).get(q), pub_rows.get(c.d, {}).get(q)
            pa = pa / pb if None not in (pa, pb) and pb else None
            pb = pc / pd if None not in (pc, pd) and pd else None
        if c.kind == "within":
            vb, pb = (va if va is not None else None), pa
            parts.append(_fmt(va, q))
        else:
            parts.append(_side(c.kind, q, va, vb, c.ratio))
        timed_q = _timed(q) or _timed(qb)
        if va is None or vb is None:
            verdicts.append(None)
        elif c.kind in ("ratio", "within"):
            assert ra is not None and rb is not None  # our_value of a missing row is None
            na = _noise(ra, q) if _timed(q) and ra.get("device") != CPU_SOFTWARE else 0.0
            nb = _noise(rb, qb) if _timed(qb) and rb.get("device") != CPU_SOFTWARE else 0.0
            lo, hi = _interval(c.kind, va, vb, na, nb)
            bv = _bound_verdict(window, lo, hi)
            verdicts.append(bv is not False and (bv if bv is not None else True))
            if bv is None:
                timing.add(INCONCLUSIVE)
            if (na or nb) and bv is not None:
                parts[-1] += f" (within the noise {lo:.3g}–{hi:.3g}" + ("×)" if c.kind == "ratio" else ")")
        elif c.kind == "gap" and timed_q:  # each ratio within its rows' noise: a/b must exceed c/d throughout
            assert gap_sides is not None  # set above for kind "gap"
            (lo1, hi1), (lo2, hi2) = (
                _interval("ratio", v1, v2, *(_noise(r, q) if _device(r) not in (None, CPU_SOFTWARE) else 0.0
                                             for r in (r1, r2)))
                for r1, r2, v1, v2 in gap_sides)
            bv = True if lo1 > hi2 else (False if hi1 <= lo2 else None)
            verdicts.append(bv is not False)
            if bv is None:
                timing.add(INCONCLUSIVE)
            if (lo1, hi1, lo2, hi2) != (va, va, vb, vb):
                parts[-1] += f" (within the noise {lo1:.3g}–{hi1:.3g}× vs {lo2:.3g}–{hi2:.3g}×)"
        else:
            verdicts.append(_compare(c.kind, q, va, vb, c.ratio))
        if timed_q:
            for i, (r1, r2, v1, v2) in enumerate(timed):  # a gap's second pair (c, d) is of quantity q
                if None not in (r1, r2, v1, v2):
                    timing.add(time_verdict(r1, r2, v1, v2, "ratio" if c.kind == "gap" else c.kind,
                                            q, qb if i == 0 else q))
        if c.kind == "within":
            if pa is not None:
                pub_parts.append(_fmt(pa, q))
        elif pa is not None and pb is not None:
            pub_parts.append(_side(c.kind, q, pa, pb, c.ratio))
    if any(v is None for v in verdicts) or NOT_MEASURED in timing:  # a missing row, or times of no device
        verdict = NOT_MEASURED
    elif c.scales and scale_name not in c.scales:
        verdict = NOT_AT_SCALE.format(scale=scale_name)
    elif NOT_MEASURABLE in timing or INCONCLUSIVE in timing:
        verdict = NOT_MEASURABLE if NOT_MEASURABLE in timing else INCONCLUSIVE
    else:
        verdict = HOLDS if all(verdicts) else FAILS
    published = c.published or "; ".join(pub_parts) or "stated in the paper"
    if c.kind in ("ratio", "within") and c.ratio:
        published += f" (holds if within {_bounds(c)})"
    reason = ""
    if verdict in (FAILS, INCONCLUSIVE):
        reason = _reason(c, found) or ("the difference lies within the rows' timing noise (IQR)"
                                       if verdict == INCONCLUSIVE else "not explained yet")
    return {"text": c.text, "where": c.where, "published": published, "ours": "; ".join(parts),
            "verdict": verdict, "rule": rule_text(c), "reason": reason, "paper": not c.ours}


def _with_setup_checks(claims, judged: list[dict]) -> list[dict]:
    """``judged`` with :data:`SETUP_UNMET` for each claim whose ``requires`` claim does not hold (a verdict
    that only reports missing rows, :data:`NOT_MEASURED`, stays)."""
    verdicts = {j["text"]: j["verdict"] for j in judged}
    for c, j in zip(claims, judged):
        if c.requires and j["verdict"] != NOT_MEASURED and verdicts.get(c.requires) != HOLDS:
            j.update(verdict=SETUP_UNMET, reason=f"the set-up check '{c.requires}' reads: "
                                                 f"{verdicts.get(c.requires, 'missing from the entry')}")
    return judged


def _premise(c: Claim, found: dict, pub_rows: dict, scale_name: str) -> dict:
    """A premise: the published and measured sides as for a claim, ``why`` in place of a verdict."""
    j = _judge(c, found, pub_rows, scale_name)
    return {"text": c.text, "where": c.where, "published": j["published"], "ours": j["ours"],
            "verdict": PREMISE, "why": c.why}


def _found(entry: Reproduction, df, scale_name: str) -> tuple[dict, dict]:
    """Our row for each of ``entry``'s rows in the results table ``df`` (row id → row dict or None), and how
    many rows matched each."""
    scale = entry.scales.get(scale_name, {})
    recs = []
    for _, r in df.iterrows():
        d = r.to_dict()
        for c in ("params", "effect_params", "scene_params", "raw_ms", "memory", "stage_iqr"):
            d[c] = as_dict(d.get(c))
        recs.append(d)
    found, matches = {}, {}
    for pr in entry.rows:
        found[pr["id"]], matches[pr["id"]] = find_row(recs, scale_match(pr["match"], scale))
    return found, matches


def measured_reasons(entry: Reproduction, df, scale_name: str = "paper") -> dict[str, str]:
    """Each claim's measured reason (a callable ``reason``) evaluated on the rows of ``df`` whatever its
    verdict, by claim text: what a reason would print, for checking that the run records what it quotes."""
    found, _ = _found(entry, df, scale_name)
    return {c.text: _reason(c, found) for c in entry.claims if callable(c.reason)}


def evaluate(entry: Reproduction, df, scale_name: str = "paper") -> dict:
    """Published vs ours for every row and claim of ``entry`` on a results table ``df``.

    Returns a JSON-able dict (also written as ``reproduce.json``): ``rows`` (one line per row ×
    quantity), ``claims`` (with verdicts; ``paper`` false for a claim of ours), ``premises`` (no verdict),
    setup strings and notes.
    """
    scale = entry.scales.get(scale_name, {})
    found, matches = _found(entry, df, scale_name)
    rows_out = []
    for pr in entry.rows:
        m = scale_match(pr["match"], scale)
        ours, n = found[pr["id"]], matches[pr["id"]]
        cfg = "no matching row in this run"
        if ours is not None:
            d = effect_d_max(ours)
            shown = _shown_params(ours, m)
            cfg = (f"{ours.get('scene')}"
                   + (f" ({', '.join(f'{k}={v}' for k, v in ours['scene_params'].items())})" if ours['scene_params'] else "")
                   + f", {ours.get('method')}" + (f" ({', '.join(f'{k}={fmt_value(v)}' for k, v in shown.items())})" if shown else "")
                   + (f", d_max = {fmt_value(d)}{'' if math.isinf(d) else ' m'} ({effect_param(ours, 'falloff', 'step')})"
                      if d is not None else "")
                   + f", {ours.get('width')}×{ours.get('height')}" + (f" [{n} matches]" if n > 1 else ""))
        qs = row_quantities(pr) or ["time_ms"]
        for q in qs:
            pub = pr.get(q)
            ov = our_value(ours, q)
            rows_out.append({"id": pr["id"], "label": pr["label"], "paper_setup": pr.get("paper_setup", ""),
                             "ours_config": cfg, "quantity": f"{quantity(q)[3]}" + (f" ({quantity(q)[1]})" if quantity(q)[1] else ""),
                             "published": _fmt(pub, q) if pub is not None else "not published",
                             "ours": _fmt(ov, q), "ratio": _versus(ov, pub, q),
                             "published_value": pub, "ours_value": ov,
                             "frames": _int_or_dash(ours, "frames"), "ref_spp": _int_or_dash(ours, "ref_spp"),
                             "iqr": (_fmt(_noise(ours, q), "rays_per_s" if q == "rays_per_s" else "time_ms")
                                     if ours is not None and _timed(q) else "–")})
    pub_rows = {pr["id"]: pr for pr in entry.rows}
    claims_out = _with_setup_checks(entry.claims, [_judge(c, found, pub_rows, scale_name) for c in entry.claims])
    premises_out = [_premise(c, found, pub_rows, scale_name) for c in entry.premises]
    ok = df[df["status"] == "ok"] if "status" in df else df
    r0 = ok.iloc[0] if len(ok) else (df.iloc[0] if len(df) else None)
    if r0 is not None:
        sizes = sorted({f"{w}x{h}" for w, h in zip(df["width"], df["height"])})
        gpu = r0.get("gpu_name")
        our_setup = (f"device {r0.get('device')}, {r0.get('gl_renderer')}" + (f", GPU {gpu}" if gpu else "")
                     + f", {', '.join(sizes)}, scale '{scale_name}'")
    else:
        our_setup = "no rows"
    return {"key": entry.key, "paper": entry.paper, "title": entry.title, "source": entry.source,
            "published_setup": f"{entry.hardware}, {entry.resolution.replace('x', '×')}, {entry.paper_scene}",
            "our_setup": our_setup, "scale": scale_name, "device": None if r0 is None else r0.get("device"),
            "run": _run_line(ok if len(ok) else df),
            "rows": rows_out, "claims": claims_out, "premises": premises_out, "notes": list(entry.notes),
            "errors": [f"{r.get('scene')} {r.get('method')}: {r.get('status')}" for _, r in df.iterrows()
                       if r.get("status") != "ok"]}


def _int_or_dash(r, col) -> str:
    v = _float(r.get(col)) if r is not None else None
    return "–" if v is None else str(int(v))


def _run_line(df) -> str:
    """Where and when the rows were measured: commit (dirty), driver, date range of the rows."""
    def vals(col):
        if col not in df:
            return []
        return sorted({str(v) for v in df[col] if v is not None and str(v) not in ("", "nan", "None", "<NA>")})
    commits = vals("commit")
    dirty = "dirty" in df and any(str(v) == "True" for v in df["dirty"])
    times = vals("time")
    date = "–" if not times else (times[0] if times[0] == times[-1] else f"{times[0]} – {times[-1]}")
    return (f"commit {', '.join(c[:12] for c in commits) or '–'}{' (dirty)' if dirty else ''}, "
            f"driver {', '.join(vals('driver')) or '–'}, date {date}")


# --------------------------------------------------------------------------------------------------
# printing


def _table(headers, rows) -> list[str]:
    widths = [max(len(str(h)), *(len(str(r[i])) for r in rows)) if rows else len(str(h))
              for i, h in enumerate(headers)]
    line = lambda cells: "  ".join(str(c).ljust(w) for c, w in zip(cells, widths)).rstrip()
    return [line(headers), line(["-" * w for w in widths])] + [line(r) for r in rows]


def format_text(res: dict) -> str:
    out = [f"{res['key']}: {res['title']}", f"  source:    {res['paper']}, {res['source']}",
           f"  published: {res['published_setup']}", f"  ours:      {res['our_setup']}"]
    if res.get("run"):
        out.append(f"  run:       {res['run']}")
    if res.get("device") == "cpu-software":
        out.append("  note: device = cpu-software, our times are wall clock on a software rasterizer shared with "
                   "other work: every time claim is 'not measurable here'")
    out += [f"  not run:   {n}" for n in res.get("not_run", ())]
    out.append("")
    out += _table(["row", "quantity", "published", "ours", "ours vs published", "our configuration"],
                  [[r["label"], r["quantity"], r["published"], r["ours"], r["ratio"], r["ours_config"]]
                   for r in res["rows"]])
    for title, group in _claim_groups(res):
        out += ["", title]
        out += _table(["#", "claim", "published", "ours", "verdict"],
                      [[i + 1, c["text"], c["published"], c["ours"], c["verdict"]] for i, c in group])
    out += ["", "verdict rules and windows:"] + [f"  [{i + 1}] {c.get('rule', '')}" for i, c in enumerate(res["claims"])]
    out.append(f"  {TIMING_RULE}")
    if res.get("premises"):
        out += ["", PREMISES_TITLE]
        out += _table(["#", "premise", "published", "ours"],
                      [[f"P{i + 1}", p["text"], p["published"], p["ours"]] for i, p in enumerate(res["premises"])])
        out += ["", "why each premise cannot fail:"] + [f"  [P{i + 1}] {p['why']}" for i, p in enumerate(res["premises"])]
    if res.get("errors"):
        out += ["", "failed rows:"] + [f"  {e}" for e in res["errors"]]
    out += [""] + [f"note: {n}" for n in res["notes"]]
    return "\n".join(out)


PAPER_CLAIMS = "the paper's claims (verdicts):"
OUR_CLAIMS = "claims of ours, not the paper's (verdicts on our own comparisons, kept apart):"
PREMISES_TITLE = ("premises (the paper's statements that our set-up decides by construction: our numbers beside "
                  "them, no verdict; never counted as holding or failing):")


def _claim_groups(res: dict) -> list:
    """[(title, [(index, claim), ...]), ...]: the paper's claims, then ours (``paper`` false), each group
    only when it has claims; indices are the claims' positions (their numbers in the rules)."""
    claims = list(enumerate(res["claims"]))
    groups = [(PAPER_CLAIMS, [(i, c) for i, c in claims if c.get("paper", True)]),
              (OUR_CLAIMS, [(i, c) for i, c in claims if not c.get("paper", True)])]
    return [(t, g) for t, g in groups if g]


def _md(s) -> str:
    return str(s).replace("|", "\\|").replace("\n", " ")


def format_markdown(res: dict) -> str:
    out = [f"# {_md(res['key'])}: {_md(res['title'])}", "",
           f"- source: {_md(res['paper'])}, {_md(res['source'])}",
           f"- published: {_md(res['published_setup'])}", f"- ours: {_md(res['our_setup'])}"]
    if res.get("run"):
        out.append(f"- run: {_md(res['run'])}")
    if res.get("device") == "cpu-software":
        out.append("- **device = cpu-software: our times are wall clock on a software rasterizer** shared with "
                   "other work: every time claim is *not measurable here*")
    out += [f"- not run: {_md(n)}" for n in res.get("not_run", ())]
    out += ["", "| row | paper setup | our configuration | quantity | published | ours | IQR | frames | reference spp "
                "| ours vs published |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in res["rows"]:
        out.append("| " + " | ".join(_md(x) for x in (r["label"], r["paper_setup"], r["ours_config"], r["quantity"],
                                                     r["published"], r["ours"], r.get("iqr", "–"),
                                                     r.get("frames", "–"), r.get("ref_spp", "–"), r["ratio"])) + " |")
    for title, group in _claim_groups(res):
        out += ["", _md(title[0].upper() + title[1:]), "",
                "| # | claim | where | published | ours | verdict | reason | rule and window |",
                "|---|---|---|---|---|---|---|---|"]
        for i, c in group:
            out.append("| " + " | ".join(_md(x) for x in (i + 1, c["text"], c["where"], c["published"], c["ours"],
                                                         f"**{c['verdict']}**", c.get("reason", ""),
                                                         c.get("rule", ""))) + " |")
    out += ["", _md(TIMING_RULE)]
    if res.get("premises"):
        out += ["", _md(PREMISES_TITLE[0].upper() + PREMISES_TITLE[1:]), "",
                "| # | premise | where | published | ours | why it cannot fail |", "|---|---|---|---|---|---|"]
        for i, p in enumerate(res["premises"]):
            out.append("| " + " | ".join(_md(x) for x in (f"P{i + 1}", p["text"], p["where"], p["published"],
                                                         p["ours"], p["why"])) + " |")
    if res.get("errors"):
        out += ["", "Failed rows:", ""] + [f"- {_md(e)}" for e in res["errors"]]
    out += ["", "Notes:", ""] + [f"- {_md(n)}" for n in res["notes"]]
    return "\n".join(out) + "\n"


# --------------------------------------------------------------------------------------------------
# running


def suite_file(entry: Reproduction) -> Path:
    """The entry's suite: ``suite.toml`` in the table's folder (:attr:`Reproduction.folder`, which
    :func:`registry` sets; an installed package carries the file as package data)."""
    if entry.folder is None:
        raise ValueError(f"{entry.key} has no folder: only the entries of registry() know their suite")
    return entry.folder / TABLE_SUITE


def suite_label(entry: Reproduction) -> str:
    """Where the entry's suite is, as a user finds it: relative to the folder that holds the ldbench package
    (the checkout, or site-packages), e.g. ``ldbench/reports/reproductions/aalund2015/fig8/suite.toml``; the
    whole path for a table folder elsewhere."""
    path = suite_file(entry)
    root = Path(__file__).resolve().parents[2]
    return path.relative_to(root).as_posix() if path.is_relative_to(root) else str(path)


def get_entry(key: str) -> Reproduction:
    reg = registry()
    if key not in reg:
        raise LdbenchError(f"unknown table {key!r} (known: {', '.join(reg)}; see ldbench reproduce --list)")
    return reg[key]


def without_unfetched_scenes(suite, key: str = "") -> tuple:
    """(the suite without the jobs whose scene reads a registered scene that is not fetched, one line per
    such scene saying which jobs did not run and how to fetch it). The other jobs run: their rows and
    claims are shown, the missing rows read 'not measured'. When no job is left: one
    :class:`LdbenchError` line naming what to fetch."""
    missing: dict = {}
    for i, j in enumerate(suite.jobs):
        name = registered_needed(j.scene)
        if name and scene_registry.status(scene_registry.get(name)) != "fetched":
            missing.setdefault(name, []).append(i)
    if not missing:
        return suite, []
    dropped = {i for ids in missing.values() for i in ids}
    lines = [f"{len(ids)} job{'s' if len(ids) > 1 else ''} on "
             f"{', '.join(sorted({suite.jobs[i].scene for i in ids}))} (scene {name!r} is not fetched: run "
             f"{scene_registry.fetch_hint(name)})" for name, ids in missing.items()]
    if len(dropped) == len(suite.jobs):
        raise LdbenchError(f"{key or suite.name}: nothing to run: " + "; ".join(lines))
    return dataclasses.replace(suite, jobs=[j for i, j in enumerate(suite.jobs) if i not in dropped]), lines


def reproduce(key: str, *, scale: str = "paper", size: str | None = None, out=None, from_run=None,
              progress: bool = True, report: bool = True) -> tuple[dict, Path]:
    """Run (or reuse) the entry's suite, evaluate it, write ``reproduce.md``/``.json``; returns
    (result dict, run directory)."""
    entry = get_entry(key)
    if scale not in entry.scales:
        raise LdbenchError(f"unknown scale {scale!r} for {key} (known: {', '.join(entry.scales)})")
    if from_run is not None:
        run_dir = Path(from_run)
        if out is not None:
            raise LdbenchError(f"--from-run evaluates {run_dir} where it is (its reproduce.md and .json): "
                               "--out does not apply; drop one of them")
        if not run_dir.is_dir():
            raise LdbenchError(f"--from-run: {run_dir} is not a directory")
        df = read_results(run_dir)  # refuses a partial or foreign folder in one line
        if is_run_dir(run_dir):  # a run of another suite would leave every claim 'not measured'
            ran = json.loads((run_dir / "suite.json").read_text(encoding="utf-8")).get("name")
            want = load_suite(suite_file(entry)).name if suite_file(entry).is_file() else None
            if want is not None and ran != want:
                raise LdbenchError(f"--from-run: {run_dir} is a run of suite {ran!r}, not of {key}'s suite {want!r}")
    else:
        path = suite_file(entry)
        if not path.is_file():
            raise LdbenchError(f"the suite of {key} is missing: {path}")
        suite = scale_suite(load_suite(path), entry.scales[scale], size)
        suite, not_run = without_unfetched_scenes(suite, key)
        run_dir = Path(out) if out else Path("runs") / f"{key}-{scale}-{time.strftime('%Y%m%d-%H%M%S')}"
        run_jobs(suite, run_dir, progress=progress, report=False)
        df = read_results(run_dir)
    try:
        res = evaluate(entry, df, scale)
        if from_run is None:
            res["not_run"] = not_run
        atomic_write_text(run_dir / "reproduce.json", json.dumps(res, indent=1, default=str))
        atomic_write_text(run_dir / "reproduce.md", format_markdown(res))
        if report:
            from .report import write_report

            write_report(run_dir)
    except KeyboardInterrupt:
        raise Interrupted(f"the run's rows are kept in {run_dir}; evaluate them without rendering again: "
                          f"ldbench reproduce {key} --from-run {run_dir}") from None
    return res, run_dir


OURS_LABEL = "*ours, not the paper's:* "
CLAIMS_BEGIN, CLAIMS_END = "<!-- claims:begin (scripts/claims_md.py writes this part) -->", "<!-- claims:end -->"


def claims_markdown() -> str:
    """The generated part of docs/reference/claims.md: for every entry (grouped by paper), its source, the command that
    tests it, each claim with where the paper says it, its kind and its verdict rule and window (a claim of
    ours labelled), and its premises with why each cannot fail."""
    out, paper = [f"Timing rule {_md(TIMING_RULE)}.", ""], None
    for e in registry().values():
        if e.paper != paper:
            paper = e.paper
            out += [f"### {paper}", ""]
        out += [f"#### `{e.key}`: {_md(e.title)}", "",
                f"{_md(e.source)}; the paper's {_md(e.hardware)}, {e.resolution.replace('x', '×')}. "
                f"`ldbench reproduce {e.key}` (GPU, paper scale; `--scale ci` on llvmpipe).", "",
                "| # | claim | where | verdict rule and window |", "|---|---|---|---|"]
        out += [f"| {i + 1} | {OURS_LABEL if c.ours else ''}{_md(c.text)} | {_md(c.where)} | {_md(rule_text(c))} |"
                for i, c in enumerate(e.claims)]
        if e.premises:
            out += ["", "Premises (our set-up decides them: printed with our numbers, no verdict):", "",
                    "| # | premise | where | why it cannot fail |", "|---|---|---|---|"]
            out += [f"| P{i + 1} | {_md(c.text)} | {_md(c.where)} | {_md(c.why)} |" for i, c in enumerate(e.premises)]
        out.append("")
    return "\n".join(out)


def list_text() -> str:
    lines = []
    for e in registry().values():
        lines.append(f"{e.key:<18} {e.title}")
        lines.append(f"{'':<18} {e.paper} {e.source}; {e.hardware}, {e.resolution}; suite {suite_label(e)}; "
                     f"scales: {', '.join(e.scales)}")
    return "\n".join(lines)


def main_cli(args) -> int:
    if args.list:
        print(list_text())
        return 0
    if not args.table:
        raise LdbenchError("ldbench reproduce needs a TABLE (see ldbench reproduce --list)")
    res, run_dir = reproduce(args.table, scale=args.scale, size=args.size, out=args.out,
                             from_run=args.from_run, progress=not args.no_progress,
                             report=not args.no_report)
    print(format_text(res))
    print(f"\nwrote {run_dir / 'reproduce.md'}")
    return 0
