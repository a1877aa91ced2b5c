"""Result records: machine and commit metadata, result rows, ``results.parquet`` + ``results.csv``.

One row per (suite, scene, method, effect, params) (docs/design.md, "Records and reports"). The columns
are :data:`COLUMNS`, each with a type in :data:`COLUMN_TYPES`:

* ``str``, ``int``, ``float``, ``bool`` scalars (missing values: None, NaN for floats);
* ``json``: nested values (dicts, lists, dataclasses such as a method's ``Params``) stored as JSON
  strings, so Parquet and CSV hold the same text; :func:`read_results` parses them back.

Every column's type, unit and meaning is in docs/reference/results-columns.md. Every file carries
:data:`SCHEMA_VERSION`: as the ``schema_version`` column, and in ``results.parquet`` also as the
Parquet key-value metadata ``ldbench.schema_version``. The rule for changing it is written there too
(major: a column removed, renamed, retyped or its meaning changed; minor: a column added).

Timing columns follow the timing protocol: ``total_ms`` is the median of the per-frame totals,
``total_ms_iqr`` its interquartile range, ``wall_ms`` the median wall-clock frame time, ``stage_ms`` and
``stage_iqr`` map each stage to its median and IQR, ``raw_ms`` keeps every sample
(``{stage: [...], "total": [...], "wall": [...]}``); :func:`timing_fields` computes them all from
``raw_ms``. Quartiles are numpy's default (linear interpolation, Hyndman-Fan type 7).

A typical runner::

    info = machine_info(gpu.ctx.info)
    base = {**machine_columns(info), **git_columns(git_info(repo))}
    rows.append(make_row(**base, run_id=run_id, scene="cornell", method="ldm-ao", effect="ao",
                         params=method.params, **timing_fields(raw_ms), **metrics))
    write_results(rows, out_dir)
"""
from __future__ import annotations

import dataclasses
import datetime as _dt
import hashlib
import importlib.metadata
import json
import math
import os
import platform
import re
import shutil
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np

from ldbench.core.device import classify_device  # noqa: F401 (the one rule; re-exported)
from ldbench.core.effects.base import effect_columns
from ldbench.core.errors import LdbenchError
from ldbench.core.files import atomic_write
from .naming import key_slug
from ldbench.core.plugins import LDBENCH_ROOT, git_info, git_info_from_env  # noqa: F401 (re-exported: records' git columns)
from ldbench.core.plugins import ldbench_version, provenance

# Heavy: pandas and pyarrow are imported where a table is built or read, so importing this module stays light;
# pynvml is optional (NVIDIA machines only).

RESULTS_PARQUET = "results.parquet"
RESULTS_CSV = "results.csv"

#: Version of the results schema, "MAJOR.MINOR" (docs/reference/results-columns.md, "Schema version"): MAJOR
#: goes up when a column is removed, renamed, retyped or changes meaning or unit, MINOR when a column is
#: added. Readers accept every file of the same MAJOR.
SCHEMA_VERSION = "1.1"
#: The Parquet key-value metadata key holding :data:`SCHEMA_VERSION`.
SCHEMA_VERSION_KEY = b"ldbench.schema_version"

#: Column name -> type, in the order the files list them.
COLUMN_TYPES: dict[str, str] = {
    "schema_version": "str", "run_id": "str", "suite": "str", "time": "str", "commit": "str", "dirty": "bool",
    "scene": "str", "scene_hash": "str", "scene_params": "json", "triangles": "int",
    "method": "str", "paper": "str", "effect": "str", "effect_params": "json", "params": "json",
    "ldbench_version": "str", "method_module": "str", "method_dist": "str", "method_version": "str",
    "method_commit": "str", "method_dirty": "bool", "timing_source": "str",
    "width": "int", "height": "int", "seed": "int",
    "device": "str", "gl_renderer": "str", "gl_version": "str", "driver": "str", "cpu": "str",
    "gpu_name": "str", "egl_device": "int", "cuda_device": "str", "pci_bus_id": "str",
    "machine_key": "str", "machine": "json",
    "warmup": "int", "frames": "int",
    "total_ms": "float", "total_ms_iqr": "float", "wall_ms": "float",
    "stage_ms": "json", "stage_iqr": "json", "raw_ms": "json",
    "memory_bytes": "int", "memory": "json", "counters": "json",
    "structure_bytes": "int",
    **effect_columns(),  # each effect's own metric columns (EffectSpec.columns), the in-tree effects' by name
    "metric_settings": "json",
    "ref_spp": "int", "ref_variant": "str", "ref_key": "str", "ref_noise": "json",
    "status": "str", "images": "json",
}
COLUMNS = tuple(COLUMN_TYPES)
JSON_COLUMNS = tuple(c for c, t in COLUMN_TYPES.items() if t == "json")
#: The columns every reader of a results table relies on (what a row is and whether it ran): a table
#: without one of them is not ldbench's. :func:`check_columns` is the one check; :func:`read_results`
#: (report, reproduce, compare, history, run directories) applies it to everything it reads.
SCHEMA_COLUMNS = ("scene", "method", "effect", "effect_params", "params", "width", "height", "run_id", "status")

_SUBPROCESS_TIMEOUT_S = 10
#: The range of an ``int`` column (Parquet int64); :func:`make_row` refuses a value outside it.
INT_MIN, INT_MAX = -(2 ** 63), 2 ** 63 - 1


# --------------------------------------------------------------------------------------------------
# machine


def _driver_from_gl_version(gl_version: str | None) -> str | None:
    """Driver part of a GL version string: ``"4.5 (Core Profile) Mesa 23.2.1"`` -> ``"Mesa 23.2.1"``,
    ``"4.6.0 NVIDIA 550.54.15"`` -> ``"NVIDIA 550.54.15"``; otherwise what follows the version number."""
    if not gl_version:
        return None
    m = re.search(r"(Mesa|NVIDIA)\s+\S+", gl_version)
    if m:
        return m.group(0)
    rest = re.sub(r"^\s*\d+(\.\d+)*\s*(\((Core|Compatibility) Profile\))?\s*", "", gl_version).strip()
    return rest or None


def _cpu_model() -> str | None:
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as f:
            for line in f:
                key, _, value = line.partition(":")
                if key.strip() in ("model name", "Model", "Hardware") and value.strip():
                    return value.strip()
    except OSError:
        pass
    return platform.processor() or None


def _version(dist: str) -> str | None:
    try:
        return importlib.metadata.version(dist)
    except importlib.metadata.PackageNotFoundError:
        return None


def _float_or_none(s):
    try:
        v = float(s)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def nvidia_gpu_info() -> dict:
    """GPU name, driver, SM and memory clocks (MHz) and total memory (MiB) of the first NVIDIA GPU.

    Asks ``nvidia-smi`` (with a timeout), else ``pynvml``; all values are None when neither answers.
    Clocks are the current ones at the time of the query.
    """
    out: dict[str, str | float | int | None] = {
        "gpu_name": None, "gpu_driver": None, "gpu_clock_sm_mhz": None, "gpu_clock_mem_mhz": None,
        "gpu_memory_mib": None, "gpu_count": None}
    exe = shutil.which("nvidia-smi")
    if exe:
        try:
            p = subprocess.run(
                [exe, "--query-gpu=name,driver_version,clocks.sm,clocks.mem,memory.total",
                 "--format=csv,noheader,nounits"],
                capture_output=True, text=True, timeout=_SUBPROCESS_TIMEOUT_S)
            lines = [ln for ln in p.stdout.splitlines() if ln.strip()] if p.returncode == 0 else []
        except (OSError, subprocess.SubprocessError):
            lines = []
        if lines:
            f = [x.strip() for x in lines[0].split(",")]
            if len(f) >= 5:
                out.update(gpu_name=f[0], gpu_driver=f[1], gpu_clock_sm_mhz=_float_or_none(f[2]),
                           gpu_clock_mem_mhz=_float_or_none(f[3]), gpu_memory_mib=_float_or_none(f[4]),
                           gpu_count=len(lines))
                return out
    try:
        import pynvml
    except ImportError:
        return out
    try:
        pynvml.nvmlInit()
        try:
            h = pynvml.nvmlDeviceGetHandleByIndex(0)
            name = pynvml.nvmlDeviceGetName(h)
            drv = pynvml.nvmlSystemGetDriverVersion()
            out.update(
                gpu_name=name.decode() if isinstance(name, bytes) else name,
                gpu_driver=drv.decode() if isinstance(drv, bytes) else drv,
                gpu_clock_sm_mhz=float(pynvml.nvmlDeviceGetClockInfo(h, pynvml.NVML_CLOCK_SM)),
                gpu_clock_mem_mhz=float(pynvml.nvmlDeviceGetClockInfo(h, pynvml.NVML_CLOCK_MEM)),
                gpu_memory_mib=pynvml.nvmlDeviceGetMemoryInfo(h).total / 2**20,
                gpu_count=int(pynvml.nvmlDeviceGetCount()),
            )
        finally:
            pynvml.nvmlShutdown()
    except Exception:  # NVML errors: no usable GPU; keep the None fields
        pass
    return out


def machine_info(gl_info: dict | None = None) -> dict:
    """Describe the machine a run executes on.

    Parameters
    ----------
    gl_info : dict, optional
        ``moderngl.Context.info``-like dict with ``GL_RENDERER``, ``GL_VERSION``, ``GL_VENDOR``.

    Returns
    -------
    dict
        ``hostname, os, cpu, cpu_count, python, numpy, moderngl, mitsuba, drjit`` (package versions
        from their metadata; nothing is imported), ``gl_renderer, gl_version, gl_vendor``, ``device``
        (:func:`classify_device`), ``gpu_name, gpu_driver, gpu_clock_sm_mhz, gpu_clock_mem_mhz,
        gpu_memory_mib, gpu_count`` (:func:`nvidia_gpu_info`; None without NVIDIA tools), and
        ``driver``: the NVIDIA driver version where known, else the driver part of ``GL_VERSION``.
    """
    gl = dict(gl_info or {})
    renderer, version, vendor = gl.get("GL_RENDERER"), gl.get("GL_VERSION"), gl.get("GL_VENDOR")
    info = {
        "hostname": socket.gethostname(),
        "os": platform.platform(),
        "cpu": _cpu_model(),
        "cpu_count": os.cpu_count(),
        "python": platform.python_version(),
        "numpy": _version("numpy"),
        "moderngl": _version("moderngl"),
        "mitsuba": _version("mitsuba"),
        "drjit": _version("drjit"),
        "gl_renderer": renderer,
        "gl_version": version,
        "gl_vendor": vendor,
        "device": classify_device(renderer, vendor),
    }
    info.update(nvidia_gpu_info())
    info["driver"] = info["gpu_driver"] or _driver_from_gl_version(version)
    return info


def machine_key(info: dict) -> str:
    """Short stable key of (device, GL renderer, driver) for per-machine history files.

    Readable prefix plus an 8-hex-digit hash of the three strings, e.g.
    ``"nvidia-nvidia-h100-80gb-hbm3-pcie-1a2b3c4d"``. Hostname, clocks and package versions do not
    enter it.
    """
    device, renderer, driver = info.get("device"), info.get("gl_renderer"), info.get("driver")
    h = hashlib.sha1(json.dumps([device, renderer, driver]).encode()).hexdigest()[:8]
    return f"{key_slug(device, 16)}-{key_slug(renderer, 32)}-{h}"


def machine_columns(info: dict) -> dict:
    """Row fields from :func:`machine_info`: ``device, gl_renderer, gl_version, driver, cpu, gpu_name,
    machine_key`` and the full dict as ``machine``; and the GPU the row ran on where the runner added
    it to ``info`` (:attr:`ldbench.core.gpu.Gpu.device_columns`): ``egl_device`` (EGL device index),
    ``cuda_device`` (the ``CUDA_VISIBLE_DEVICES`` GPU given to the job), ``pci_bus_id``."""
    return {"device": info.get("device"), "gl_renderer": info.get("gl_renderer"),
            "gl_version": info.get("gl_version"), "driver": info.get("driver"), "cpu": info.get("cpu"),
            "gpu_name": info.get("gpu_name"), "egl_device": info.get("egl_device"),
            "cuda_device": info.get("cuda_device"), "pci_bus_id": info.get("pci_bus_id"),
            "machine_key": machine_key(info), "machine": info}


# --------------------------------------------------------------------------------------------------
# git


def git_columns(info: dict) -> dict:
    """Row fields ``commit`` and ``dirty`` from :func:`git_info`."""
    return {"commit": info.get("commit"), "dirty": info.get("dirty")}


def method_columns(cls, git: dict | None = None) -> dict:
    """Row fields of where a method's class comes from (:func:`ldbench.core.plugins.provenance`):
    ``ldbench_version`` (the running ldbench's), ``method_module``, ``method_dist``, ``method_version``, ``method_commit``, ``method_dirty``
    (``git``: ldbench's own :func:`git_info`, for ldbench's built-in methods)."""
    p = provenance(cls, git)
    return {"ldbench_version": ldbench_version(), "method_module": p["module"], "method_dist": p["dist"], "method_version": p["dist_version"],
            "method_commit": p["commit"], "method_dirty": p["dirty"]}


# --------------------------------------------------------------------------------------------------
# timing


def summarize_samples(samples) -> dict:
    """Median and interquartile range of timing samples.

    Quartiles use numpy's default linear interpolation. Non-finite samples are dropped.

    Returns
    -------
    dict
        ``{"median", "iqr", "q1", "q3": float, "n": int}``; NaN statistics when no sample is left.
    """
    a = np.asarray(list(samples), dtype=np.float64).ravel()
    a = a[np.isfinite(a)]
    if a.size == 0:
        return {"median": math.nan, "iqr": math.nan, "q1": math.nan, "q3": math.nan, "n": 0}
    q1, med, q3 = (float(x) for x in np.percentile(a, [25.0, 50.0, 75.0]))
    return {"median": med, "iqr": q3 - q1, "q1": q1, "q3": q3, "n": int(a.size)}


def timing_fields(raw_ms: dict) -> dict:
    """Timing columns from raw per-frame samples.

    Parameters
    ----------
    raw_ms : dict
        ``{stage: [ms per measured frame], ..., "total": [...], "wall": [...]}``. ``"total"`` (the
        per-frame GPU total) defaults to the per-frame sum of the stages; ``"wall"`` is optional.

    Returns
    -------
    dict
        ``total_ms, total_ms_iqr, wall_ms, stage_ms, stage_iqr, raw_ms, frames`` (stage order kept).
    """
    raw = {str(k): [float(x) for x in v] for k, v in raw_ms.items()}
    stages = {k: v for k, v in raw.items() if k not in ("total", "wall")}
    if "total" not in raw and stages:
        lengths = {len(v) for v in stages.values()}
        if len(lengths) != 1:
            raise LdbenchError(f"stages have different sample counts {sorted(lengths)}; pass 'total'")
        raw["total"] = [float(sum(x)) for x in zip(*stages.values())]
    total = summarize_samples(raw.get("total", []))
    wall = summarize_samples(raw.get("wall", []))
    sums = {k: summarize_samples(v) for k, v in stages.items()}
    return {
        "total_ms": total["median"], "total_ms_iqr": total["iqr"], "wall_ms": wall["median"],
        "stage_ms": {k: s["median"] for k, s in sums.items()},
        "stage_iqr": {k: s["iqr"] for k, s in sums.items()},
        "raw_ms": raw, "frames": total["n"] or wall["n"],
    }


# --------------------------------------------------------------------------------------------------
# rows


def _json_default(o):
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if dataclasses.is_dataclass(o) and not isinstance(o, type):
        return dataclasses.asdict(o)
    if isinstance(o, (Path, os.PathLike)):
        return os.fspath(o)
    if isinstance(o, (set, frozenset)):
        return sorted(o)
    raise TypeError(f"{type(o).__name__} is not JSON serializable")


def to_json(value) -> str | None:
    """JSON text of a nested value (None stays None; a string is taken as JSON already if it parses).

    NumPy scalars and arrays, dataclasses (e.g. a method's ``Params``), paths and sets are converted;
    dict key order is kept (stage order matters for reports). Non-finite floats are written as
    ``NaN``/``Infinity`` (Python's JSON dialect).
    """
    if value is None:
        return None
    if isinstance(value, str):
        try:
            json.loads(value)
            return value
        except ValueError:
            pass
    return json.dumps(value, default=_json_default)


def _is_missing(v) -> bool:
    if v is None:
        return True
    if isinstance(v, (dict, list, tuple, str, np.ndarray)):
        return False
    import pandas as pd

    missing = pd.isna(v)  # None, NaN, pandas NA and NaT
    return bool(missing) if isinstance(missing, (bool, np.bool_)) else False


def _coerce(col: str, kind: str, v):
    if kind == "json":
        if _is_missing(v):
            return None
        try:
            return to_json(v)
        except TypeError as e:
            raise LdbenchError(f"result column {col!r}: {e}") from None
    if _is_missing(v):
        return math.nan if kind == "float" else None
    try:
        if kind == "float":
            return float(v)
        if kind == "int":
            if isinstance(v, (int, np.integer)):
                i = int(v)
            else:
                f = float(v)
                if f != int(f):
                    raise ValueError(f"not an integer: {v!r}")
                i = int(f)
            if not INT_MIN <= i <= INT_MAX:  # Parquet's int64: beyond it the writer would lose every row
                raise ValueError(f"out of range: {v!r}")
            return i
        if kind == "bool":
            if isinstance(v, str):
                return {"true": True, "false": False}[v.strip().lower()]
            return bool(v)
    except (TypeError, ValueError, KeyError, OverflowError):
        what = f"{kind} in [{INT_MIN}, {INT_MAX}]" if kind == "int" else kind
        raise LdbenchError(f"result column {col!r} must be {what}, got {v!r}") from None
    return str(v)


#: The buffers of a layered structure (the layered-structure base class and its linked-list and linear
#: layouts name every buffer ``prefix + part``), after the structure's prefix.
STRUCTURE_PARTS = ("counters", "layers", "heads", "nodes", "payload", "offsets", "scan.", "depth", "pairs",
                   "splat.", "peel.")


def structure_bytes(memory: dict):
    """Bytes of the layered structures alone (LDMs, LDIs, a CDI, OIT lists) in a row's ``memory`` dict, or
    None when it holds none: the entries ``P + part`` (:data:`STRUCTURE_PARTS`) of every prefix P under
    which a structure allocated its ``counters`` and ``layers`` (every structure does). What papers count
    as "the LDMs take X MB", without the scene's geometry, G-buffers and outputs."""
    prefixes = [k[:-len("counters")] for k in memory if k.endswith("counters") and k[:-8] + "layers" in memory]
    if not prefixes:
        return None
    return int(sum(int(v) for k, v in memory.items()
                   if any(k.startswith(p) and k[len(p):].startswith(STRUCTURE_PARTS) for p in prefixes)))


def checked_memory(memory: dict, what: str = "memory") -> dict:
    """``{buffer: bytes}`` with every value a whole number of bytes >= 0 and their sum within an ``int``
    column (:data:`INT_MAX`), else one :class:`LdbenchError` line naming the buffer (a method's row then
    becomes ``error: ...``; the other rows are kept)."""
    out = {}
    for k, v in dict(memory).items():
        ok = isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))
        if ok:
            f = float(v)
            ok = math.isfinite(f) and f >= 0 and f == int(f) and int(v) <= INT_MAX
        if not ok:
            raise LdbenchError(f"{what} {k!r} must be a whole number of bytes in [0, {INT_MAX}], got {v!r}")
        out[str(k)] = int(v)
    if sum(out.values()) > INT_MAX:
        raise LdbenchError(f"{what}: the buffers sum to {sum(out.values())} bytes, more than {INT_MAX}")
    return out


def make_row(**fields) -> dict:
    """One result row with every column of :data:`COLUMNS`, values normalized to the column types.

    Missing columns are None (NaN for floats); ``time`` defaults to now (ISO 8601, UTC), ``status`` to
    ``"ok"``, ``schema_version`` to :data:`SCHEMA_VERSION`, ``memory_bytes`` to the sum of ``memory``.
    JSON columns accept dicts, lists, dataclasses and numpy values and hold JSON text. Extra fields are
    kept as extra columns (after the standard ones); their values are stored as given, dicts, lists and tuples as JSON text (not parsed back).

    Raises
    ------
    LdbenchError
        A value that does not fit its column's type (naming the column).
    """
    f = dict(fields)
    if f.get("time") is None:
        f["time"] = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
    if f.get("status") is None:
        f["status"] = "ok"
    if f.get("schema_version") is None:
        f["schema_version"] = SCHEMA_VERSION
    if f.get("memory_bytes") is None and isinstance(f.get("memory"), dict):
        f["memory"] = checked_memory(f["memory"])  # else the sum: one line, not an OverflowError
        f["memory_bytes"] = int(sum(f["memory"].values()))
    if f.get("structure_bytes") is None and isinstance(f.get("memory"), dict):
        f["structure_bytes"] = structure_bytes(f["memory"])
    row = {c: _coerce(c, t, f.get(c)) for c, t in COLUMN_TYPES.items()}
    for k, v in f.items():
        if k not in row:
            row[k] = to_json(v) if isinstance(v, (dict, list, tuple)) else v
    return row


def _frame(rows: list[dict]):
    import pandas as pd

    rows = [make_row(**r) for r in rows]  # idempotent on rows from make_row
    extra = []
    for r in rows:
        extra += [k for k in r if k not in COLUMN_TYPES and k not in extra]
    df = pd.DataFrame([{c: r.get(c) for c in (*COLUMNS, *extra)} for r in rows], columns=[*COLUMNS, *extra])
    return _apply_types(df)


def _to_int(v) -> int:
    try:
        return int(v)  # exact for ints and digit strings
    except (TypeError, ValueError):
        return int(float(v))


def _apply_types(df):
    import pandas as pd

    for c, t in COLUMN_TYPES.items():
        if c not in df:
            continue
        if t == "float":
            df[c] = pd.to_numeric(df[c], errors="coerce").astype("float64")
        elif t == "int":
            df[c] = pd.array([None if _is_missing(v) else _to_int(v) for v in df[c]], dtype="Int64")
        elif t == "bool":
            df[c] = pd.array([None if _is_missing(v) else bool(v) for v in df[c]], dtype="boolean")
        else:  # str and json text
            df[c] = pd.Series([None if _is_missing(v) else str(v) for v in df[c]], index=df.index, dtype=object)
    return df


def _write_parquet(df, path, version: str = SCHEMA_VERSION):
    """``df`` as Parquet with ``version`` (:data:`SCHEMA_VERSION`) in the file's key-value metadata."""
    import pyarrow as pa
    import pyarrow.parquet as papq

    table = pa.Table.from_pandas(df, preserve_index=False)
    table = table.replace_schema_metadata({**(table.schema.metadata or {}),
                                           SCHEMA_VERSION_KEY: version.encode()})
    papq.write_table(table, path)


def _version_key(v: str) -> tuple:
    return tuple(int(x) if x.isdigit() else -1 for x in v.split("."))


def _kept_schema_version(version: str | None, where) -> str:
    """The version a results file written with rows of a file of ``version`` declares: the newer of the two
    (same major; None: a file older than versions)."""
    if version is None:
        return SCHEMA_VERSION
    _check_schema_version(version, Path(where))  # a newer major: refused
    if version.split(".")[0] != SCHEMA_VERSION.split(".")[0]:
        raise LdbenchError(f"results {where} have schema version {version}, another major version than this "
                           f"ldbench writes ({SCHEMA_VERSION}); add rows to a new run instead")
    return max(version, SCHEMA_VERSION, key=_version_key)


def _file_schema_version(path: Path, df) -> str | None:
    """The schema version a results file declares: Parquet metadata, else its ``schema_version`` column
    (None for files written before versions existed)."""
    if path.suffix == ".parquet":
        import pyarrow.parquet as papq

        meta = papq.read_schema(path).metadata or {}
        if SCHEMA_VERSION_KEY in meta:
            return meta[SCHEMA_VERSION_KEY].decode()
    if "schema_version" in df:
        versions = {str(v) for v in df["schema_version"] if not _is_missing(v)}
        if versions:
            return max(versions, key=lambda v: tuple(int(x) for x in v.split(".") if x.isdigit()))
    return None


def _check_schema_version(version: str | None, path: Path):
    if version is None:
        return
    major = version.split(".")[0]
    if not major.isdigit():
        raise LdbenchError(f"cannot read results {path}: bad schema_version {version!r}")
    if int(major) > int(SCHEMA_VERSION.split(".")[0]):
        raise LdbenchError(f"results {path} have schema version {version}, newer than this ldbench reads "
                           f"({SCHEMA_VERSION}); update ldbench")


def write_results(rows: list[dict], out_dir, *, schema_version: str | None = None) -> dict:
    """Write ``results.parquet`` and ``results.csv`` into ``out_dir``.

    Rows from :func:`make_row` (raw dicts are passed through it). Each file is written to a temporary
    name and renamed, so a crash never leaves a truncated results file. ``schema_version``: the version of
    the file these rows were read from (rows added to an existing run): the file keeps it when it is newer
    than :data:`SCHEMA_VERSION` (a minor version only adds columns, so this ldbench's rows are valid in it);
    another major version is refused, as :func:`read_results` refuses it.

    Returns
    -------
    dict
        ``{"parquet": Path, "csv": Path}``.
    """
    out = Path(out_dir)
    version = _kept_schema_version(schema_version, out)
    out.mkdir(parents=True, exist_ok=True)
    df = _frame(list(rows))
    pq, csv = out / RESULTS_PARQUET, out / RESULTS_CSV
    atomic_write(pq, lambda p: _write_parquet(df, p, version))
    atomic_write(csv, lambda p: df.to_csv(p, index=False))
    return {"parquet": pq, "csv": csv}


def check_columns(columns, what, required=SCHEMA_COLUMNS) -> None:
    """Refuse a table without one of ``required`` (default :data:`SCHEMA_COLUMNS`): one
    :class:`LdbenchError` line naming ``what`` (e.g. the file) and the first missing columns."""
    have = set(columns)
    missing = [c for c in required if c not in have]
    if missing:
        raise LdbenchError(f"{what} is not an ldbench results table: no column {missing[0]!r}"
                           + (f" (nor {', '.join(map(repr, missing[1:4]))})" if len(missing) > 1 else ""))


#: The file a run directory being written carries (:mod:`ldbench.harness.rundir`): its rows are not a finished run.
PARTIAL_MARKER = ".ldbench-partial"


def check_not_partial(path) -> None:
    """Refuse a folder (or a file in one) that a run is still writing or was killed writing: it carries
    :data:`PARTIAL_MARKER` (``.DIR.partial-PID/``); its rows are not a finished run."""
    MARKER = PARTIAL_MARKER

    p = Path(path)
    d = p if p.is_dir() else p.parent
    if (d / MARKER).exists():
        raise LdbenchError(f"{d} is an unfinished run (a run killed or still writing it, marked "
                           f"{MARKER}); give the finished run directory")


def _parse_json(v):
    if _is_missing(v) or v == "":
        return None
    return json.loads(v) if isinstance(v, str) else v


def read_results(path_or_dir, *, unfinished: bool = False):
    """Read a results file (or a run directory's ``results.parquet``, else ``results.csv``).

    The one reader of ldbench's results (docs/reference/results-columns.md). ``path_or_dir`` is a run directory
    or a ``.parquet``/``.csv`` results file; returns a pandas DataFrame. Columns get their :data:`COLUMN_TYPES` (floats as float64, ints as nullable ``Int64``, ``dirty``
    as nullable ``boolean``, strings as objects with None for missing) and JSON columns are parsed
    back into dicts/lists. Extra columns read from CSV stay strings. ``df.attrs["schema_version"]``
    is the version the file declares (None for files older than versions); a file of a newer major
    version than :data:`SCHEMA_VERSION` is refused.

    Raises
    ------
    LdbenchError
        If no results file is found, the file type is unknown, the file cannot be parsed or lacks a
        column of :data:`SCHEMA_COLUMNS` (:func:`check_columns`), or it belongs to an unfinished run
        (:func:`check_not_partial`; ``unfinished=True``: the runner reading the run it is writing).
    """
    import pandas as pd

    p = Path(path_or_dir)
    if not unfinished:
        check_not_partial(p)
    if p.is_dir():
        for name in (RESULTS_PARQUET, RESULTS_CSV):
            if (p / name).is_file():
                p = p / name
                break
        else:
            raise LdbenchError(f"no {RESULTS_PARQUET} or {RESULTS_CSV} in {path_or_dir}")
    if not p.is_file():
        raise LdbenchError(f"results file not found: {path_or_dir}")
    if p.suffix not in (".parquet", ".csv"):
        raise LdbenchError(f"unknown results file type {p.suffix!r}: {p}")
    import pyarrow

    try:
        if p.suffix == ".parquet":
            df = pd.read_parquet(p, engine="pyarrow")
        else:
            df = pd.read_csv(p, dtype=str, keep_default_na=False)
            df = df.replace({"": None}).astype(object)
            for c in df:
                if COLUMN_TYPES.get(c) == "bool":
                    df[c] = [None if v is None else {"true": True, "false": False}[v.lower()] for v in df[c]]
        version = _file_schema_version(p, df)
        _check_schema_version(version, p)
        df = _apply_types(df)
        for c in JSON_COLUMNS:
            if c in df:
                df[c] = pd.Series([_parse_json(v) for v in df[c]], index=df.index, dtype=object)
        df.attrs["schema_version"] = version
    except (pyarrow.ArrowException, pd.errors.ParserError, pd.errors.EmptyDataError, OSError, ValueError,
            TypeError, KeyError, AttributeError) as e:  # a corrupt or foreign file: one line, not a traceback
        why = (str(e).strip().splitlines() or [type(e).__name__])[0][:200]
        raise LdbenchError(f"cannot read results {p}: {why}") from e
    check_columns(df.columns, str(p))
    return df


# --------------------------------------------------------------------------------------------------
# reading a row


def effect_param(row, name: str, default=None):
    """One parameter of a row's effect, from its ``effect_params`` column.

    ``row`` is a dict or a pandas row; ``effect_params`` a dict (as :func:`read_results` gives) or
    the JSON text stored in the files, e.g. ``{"effect": "ao", "d_max": "inf", "falloff": "step"}``.
    Returns ``default`` when the row has no such parameter. Values come as stored (``"inf"`` is text):
    typed readers such as :func:`effect_d_max` sit on top.
    """
    ep = row.get("effect_params") if hasattr(row, "get") else None
    if isinstance(ep, str):
        try:
            ep = json.loads(ep)
        except ValueError:
            return default
    if not isinstance(ep, dict):
        return default
    v = ep.get(name, default)
    return default if _is_missing(v) else v


def effect_d_max(row):
    """The row's effect parameter ``d_max`` as a float (``math.inf`` for "inf"), None when the row's
    effect has none (or it is not a number)."""
    v = effect_param(row, "d_max")
    if isinstance(v, str) and v.strip().lower() in ("inf", "+inf", "infinity"):
        return math.inf
    try:
        d = float(v)
    except (TypeError, ValueError):
        return None
    return None if math.isnan(d) else d


if __name__ == "__main__":  # pragma: no cover - quick look at this machine
    json.dump(machine_info(), sys.stdout, indent=2)
    print()
