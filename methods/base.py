"""The method-adapter contract (DESIGN.md, "Method adapter contract") and the adapter registry.

An adapter is a sub-package ``methods/<folder>/`` whose ``__init__.py`` defines a :class:`Method`
subclass with ``name``, ``paper``, ``effects`` and a ``Params`` dataclass. Adapters are discovered by
:func:`registry` (every sub-package that defines one), never listed by hand.

Params are frozen dataclasses deriving from :class:`ParamsBase`; each field is declared with
:func:`param` (default, documentation, range or choices) and validated on construction, so an unknown
or out-of-range value is one clear error naming the parameter.
"""
from __future__ import annotations

import dataclasses
import importlib
import math
import pkgutil
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from harness.errors import LdbenchError
from harness.scene import Camera


def param(default, doc: str, *, lo=None, hi=None, choices=None, paper=None):
    """A validated parameter: ``lo``/``hi`` inclusive bounds, ``choices`` allowed values,
    ``paper`` the value the paper used (shown in ``ldbench methods``)."""
    return field(default=default, metadata={"doc": doc, "lo": lo, "hi": hi, "choices": choices,
                                            "paper": paper})


@dataclass(frozen=True)
class ParamsBase:
    """Base of every adapter's ``Params``: coerces types and checks ranges on construction."""

    def __post_init__(self):
        for f in dataclasses.fields(self):
            v, md = getattr(self, f.name), f.metadata
            v = _coerce(type(f.default), v, f.name)
            if md.get("choices") is not None and v not in md["choices"]:
                raise LdbenchError(f"parameter {f.name}={v!r} not one of {list(md['choices'])}")
            if md.get("lo") is not None and not v >= md["lo"]:
                raise LdbenchError(f"parameter {f.name}={v!r} below its minimum {md['lo']}")
            if md.get("hi") is not None and not v <= md["hi"]:
                raise LdbenchError(f"parameter {f.name}={v!r} above its maximum {md['hi']}")
            object.__setattr__(self, f.name, v)

    @classmethod
    def from_dict(cls, values: dict, *, method: str = "") -> "ParamsBase":
        names = {f.name for f in dataclasses.fields(cls)}
        for k in values:
            if k not in names:
                raise LdbenchError(f"unknown parameter {k!r} for method {method!r} "
                                   f"(known: {', '.join(sorted(names)) or 'none'})")
        return cls(**values)

    def to_dict(self) -> dict:
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}

    @classmethod
    def field_names(cls) -> tuple:
        return tuple(f.name for f in dataclasses.fields(cls))

    @classmethod
    def table(cls) -> str:
        """A text table of the parameters: name, default, paper value, range, description."""
        rows = []
        for f in dataclasses.fields(cls):
            md = f.metadata
            rng = (f"{md['choices']}" if md.get("choices") else
                   f"[{md.get('lo', '')}, {md.get('hi', '')}]" if md.get("lo") is not None or md.get("hi") is not None
                   else "")
            paper = "" if md.get("paper") is None else f" (paper: {md['paper']})"
            rows.append(f"  {f.name:<16} = {f.default!r:<10} {rng:<18} {md.get('doc', '')}{paper}")
        return "\n".join(rows)


def _coerce(kind, v, name):
    """``v`` as the declared type ``kind``, strictly: a bool only from a bool (or the text true/false
    of a command line), an int from an integer (not a bool) or integral text, a float from an int or
    float (not a bool) or numeric text (``inf``), a str from a str. Anything else is an error naming
    the parameter, never a silent conversion (``directions = true`` is not 1)."""
    import numbers

    bad = LdbenchError(f"parameter {name}={v!r} is not a valid {kind.__name__}")
    if kind is bool:
        if isinstance(v, (bool, np.bool_)):
            return bool(v)
        if isinstance(v, str) and v.strip().lower() in ("true", "false"):
            return v.strip().lower() == "true"
        raise bad
    if kind is int:
        if isinstance(v, numbers.Integral) and not isinstance(v, (bool, np.bool_)):
            return int(v)
        if isinstance(v, str):
            try:
                return int(v.strip())
            except ValueError:
                raise bad from None
        raise bad
    if kind is float:
        if isinstance(v, numbers.Real) and not isinstance(v, (bool, np.bool_)):
            x = float(v)
        elif isinstance(v, str):
            try:
                x = float(v.strip())  # also "inf" / "infinity"
            except ValueError:
                raise bad from None
        else:
            raise bad
        if math.isnan(x):
            raise bad
        return x
    if kind is str:
        if isinstance(v, str):
            return v
        raise bad
    return v


@dataclass(frozen=True)
class View:
    """What one frame renders: the camera and the image size."""

    camera: Camera
    width: int
    height: int

    @property
    def aspect(self) -> float:
        return self.width / self.height


@dataclass
class Result:
    """One frame's output.

    image : H×W×C float32, row 0 at the top (C = 1 for ``ao``, 3 for radiance), for image effects
    arrays : {name: array} for effects whose output is not an image (``rays``: ``t`` per ray)
    mask : H×W bool, the pixels the method gave a value (None = all); a missing pixel counts as error
    stages_ms : filled by the runner from the GPU timer (a method does not time itself)
    memory_bytes : {buffer name: bytes} of every allocation the method holds for this frame
    counters : fragments stored, overflow, list lengths, ...
    invariants : violated invariants, each one line (e.g. "linked_nodes 10 != fragments_stored 12"); the
        runner marks the row ``degraded`` when any is listed

    ``image``, ``mask`` and every value of ``arrays`` may be zero-argument callables, ``counters`` too, and
    ``invariants`` a callable of the resolved counters: :meth:`resolve` evaluates them after timing, so a
    frame's timing never includes a read-back; the runner resolves only the frames it keeps.
    """

    image: np.ndarray | None = None
    memory_bytes: dict = field(default_factory=dict)
    counters: dict = field(default_factory=dict)
    stages_ms: dict = field(default_factory=dict)
    mask: np.ndarray | None = None
    arrays: dict = field(default_factory=dict)
    invariants: list = field(default_factory=list)

    def resolve(self) -> "Result":
        if callable(self.image):
            self.image = self.image()
        if callable(self.mask):
            self.mask = self.mask()
        self.arrays = {k: (v() if callable(v) else v) for k, v in self.arrays.items()}
        if callable(self.counters):
            self.counters = self.counters()
        if callable(self.invariants):
            self.invariants = list(self.invariants(self.counters))
        return self


class Method:
    """Base class of a method adapter. Subclasses set the class attributes and implement the hooks."""

    name: str = ""
    aliases: tuple = ()  # earlier names that still select this adapter
    paper: str = ""
    effects: frozenset = frozenset()
    Params: type = ParamsBase
    folder: Path = Path(__file__).parent
    #: the exact ray tracer ``t = oracle(scene, batch)`` (a :class:`~harness.effects.rays.RayBatch`; inf =
    #: miss), set by the harness for adapters whose parameters ask for an exact baseline (never timed)
    oracle = None

    def __init__(self, params: ParamsBase | None = None):
        self.params = params if params is not None else self.Params()

    def setup(self, gpu, scene) -> None:
        """Upload the scene and compile shaders; not timed."""
        raise NotImplementedError

    def frame(self, view: View, effect, inputs=None) -> Result:
        """Render one frame; wrap each stage in ``with gpu.stage(name):``. ``inputs`` are the effect's
        harness-built inputs (e.g. a :class:`~harness.effects.rays.RayBatch`, already uploaded), the
        same the reference receives; None for image effects."""
        raise NotImplementedError

    def exact_distances(self, scene, batch):
        """The hit distances of ``batch`` from :attr:`oracle` (an error if the harness gave none)."""
        if self.oracle is None:
            raise LdbenchError(f"method {self.name!r}: this mode needs the harness's exact ray oracle "
                               "(Method.oracle), which was not given")
        return self.oracle(scene, batch)

    def release(self) -> None:
        """Free every GPU object (everything allocated through ``self.res``)."""
        if getattr(self, "res", None) is not None:
            self.res.release()

    def setup_scene(self, gpu, scene) -> None:
        """The common part of ``setup``: ``self.res`` (memory-accounted allocations), the scene's
        triangles on the GPU (``self.geo``) and a G-buffer pass (``self.gbuf``)."""
        from methods.gbuffer import GBuffer, SceneGeometry

        self.gpu, self.scene = gpu, scene
        self.res = gpu.resources()
        self.geo = SceneGeometry(gpu, scene, self.res)
        self.gbuf = GBuffer(gpu, self.geo, self.res)

    def shader(self, name: str) -> Path:
        return Path(importlib.import_module(type(self).__module__).__file__).parent / name


def registry() -> dict:
    """{name: Method subclass} for every adapter package under ``methods/`` (discovered)."""
    package = __name__.rpartition(".")[0]  # the methods package, whatever it is installed as
    found = {}
    for mod in pkgutil.iter_modules([str(Path(__file__).parent)]):
        if not mod.ispkg:
            continue
        m = importlib.import_module(f"{package}.{mod.name}")
        for obj in vars(m).values():
            if isinstance(obj, type) and issubclass(obj, Method) and obj is not Method and obj.name:
                found[obj.name] = obj
    return dict(sorted(found.items()))


def aliases() -> dict:
    """{alias: canonical name} of every adapter that declares ``aliases`` (earlier names)."""
    return {a: name for name, cls in registry().items() for a in getattr(cls, "aliases", ())}


def canonical_name(name: str) -> str:
    """The registered name of a method given by name or alias (unknown names are returned as given)."""
    return aliases().get(name, name)


def get_method(name: str) -> type:
    reg = registry()
    name = canonical_name(name)
    if name not in reg:
        raise LdbenchError(f"unknown method {name!r} (known: {', '.join(reg) or 'none'})")
    return reg[name]
