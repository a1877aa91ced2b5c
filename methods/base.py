"""The method-adapter contract (docs/design.md, "Method adapter contract") and the adapter registry.

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
from typing import ClassVar

import numpy as np

from harness.errors import LdbenchError
from harness.scene import Camera


def param(default, doc: str, *, lo=None, hi=None, choices=None, paper=None):
    """A validated parameter: ``lo``/``hi`` inclusive bounds, ``choices`` allowed values,
    ``paper`` the value the paper used (shown in ``ldbench methods``)."""
    return field(default=default, metadata={"doc": doc, "lo": lo, "hi": hi, "choices": choices,
                                            "paper": paper})


def group(cls, doc: str, *, expose: tuple | None = None, choices: dict | None = None, paper: dict | None = None,
          **defaults):
    """A parameter group: a field holding a nested :class:`ParamsBase` ``cls`` (e.g. the
    :class:`~methods.structures.spec.StructureSpec` of a method's structure), whose parameters are named
    ``<field>.<name>`` (``cls.prefix`` must be ``"<field>."``). ``defaults``: this method's values of the
    group's fields; ``expose``: the fields a suite may set (None: all; the others stay at ``defaults``);
    ``choices``: narrower choices of a field for this method; ``paper``: the paper's value of a field."""
    return field(default_factory=lambda: cls(**defaults),
                 metadata={"group": cls, "doc": doc, "expose": expose, "choices": choices or {},
                           "paper_values": paper or {}, "defaults": defaults})


@dataclass(frozen=True)
class ParamsBase:
    """Base of every adapter's ``Params``: coerces types and checks ranges on construction.

    A method's parameters may be grouped by role (:func:`group`): the flat view (:meth:`to_dict`,
    :meth:`from_dict`, :meth:`field_names`) names a grouped parameter ``group.name``
    (``structure.source``, ``indirect.photons``). :attr:`renamed` maps each earlier flat name to its
    dotted name (and :attr:`renamed_values` an earlier name whose values changed vocabulary to the new
    parameters of each value), so suites and records written with the earlier names keep working."""

    #: the dotted prefix of this class's parameters in error messages ("structure." for a group)
    prefix: ClassVar[str] = ""
    #: earlier flat name -> its dotted name
    renamed: ClassVar[dict] = {}
    #: earlier flat name -> {earlier value: {dotted name: value, ...}} (a vocabulary that changed)
    renamed_values: ClassVar[dict] = {}

    def __post_init__(self):
        for f in dataclasses.fields(self):
            v, md, name = getattr(self, f.name), f.metadata, self.prefix + f.name
            if "group" in md:
                object.__setattr__(self, f.name, self._group_value(f, v))
                continue
            v = _coerce(type(f.default), v, name)
            if md.get("choices") is not None and v not in md["choices"]:
                raise LdbenchError(f"parameter {name}={v!r} not one of {list(md['choices'])}")
            if md.get("lo") is not None and not v >= md["lo"]:
                raise LdbenchError(f"parameter {name}={v!r} below its minimum {md['lo']}")
            if md.get("hi") is not None and not v <= md["hi"]:
                raise LdbenchError(f"parameter {name}={v!r} above its maximum {md['hi']}")
            object.__setattr__(self, f.name, v)

    @staticmethod
    def _group_value(f, v):
        """The group field ``f``'s value: a dict of exposed parameters (over the method's defaults) or an
        instance of the group's class; narrower choices checked."""
        md, gcls = f.metadata, f.metadata["group"]
        if gcls.prefix != f.name + ".":
            raise TypeError(f"group {f.name}: {gcls.__name__}.prefix is {gcls.prefix!r}, not {f.name + '.'!r}")
        if isinstance(v, dict):
            exposed = _exposed(f)
            for k in v:
                if k not in exposed:
                    raise LdbenchError(f"unknown parameter {f.name}.{k} (known: "
                                       f"{', '.join(f'{f.name}.{n}' for n in exposed)})")
            for k, allowed in md["choices"].items():  # before the group's own checks: the narrower choice
                if isinstance(v.get(k), str) and v[k] not in allowed:
                    raise LdbenchError(f"parameter {f.name}.{k}={v[k]!r} not one of {list(allowed)}")
            v = gcls(**{**md["defaults"], **v})
        elif not isinstance(v, gcls):
            raise LdbenchError(f"parameter group {f.name} must be a table of parameters, got {v!r}")
        for k, allowed in md["choices"].items():
            if getattr(v, k) not in allowed:
                raise LdbenchError(f"parameter {f.name}.{k}={getattr(v, k)!r} not one of {list(allowed)}")
        return v

    @classmethod
    def _groups(cls) -> dict:
        return {f.name: f for f in dataclasses.fields(cls) if "group" in f.metadata}

    @classmethod
    def upgrade(cls, values: dict) -> dict:
        """``values`` in the current flat names: earlier names through :attr:`renamed` and
        :attr:`renamed_values`, nested group tables (``{"structure": {"source": ...}}``, as TOML reads
        ``structure.source = ...``) flattened. The same parameter given twice with two values is an error."""
        groups, out, given = cls._groups(), {}, {}
        flat = []
        for k, v in values.items():
            if k in groups and isinstance(v, dict):
                flat += [(f"{k}.{sk}", sv) for sk, sv in v.items()]
            else:
                flat.append((k, v))
        for k, v in flat:
            if k in cls.renamed_values:
                table = cls.renamed_values[k]
                key = v.strip() if isinstance(v, str) else v
                if key not in table:
                    raise LdbenchError(f"parameter {k}={v!r} (now {cls.renamed.get(k, k)}) not one of {list(table)}")
                items = table[key]
            else:
                items = {cls.renamed.get(k, k): v}
            for nk, nv in items.items():
                if nk in out and out[nk] != nv:
                    raise LdbenchError(f"parameter {nk} given twice: {given[nk]} and {k}={v!r}")
                out[nk], given[nk] = nv, f"{k}={v!r}"
        return out

    @classmethod
    def from_dict(cls, values: dict, *, method: str = "") -> "ParamsBase":
        """The parameters of a flat dict (dotted names for grouped ones; earlier names accepted)."""
        values = cls.upgrade(values)
        groups = cls._groups()
        names = set(cls.field_names())
        top, nested = {}, {g: {} for g in groups}
        for k, v in values.items():
            if k not in names:
                raise LdbenchError(f"unknown parameter {k!r} for method {method!r} "
                                   f"(known: {', '.join(sorted(names)) or 'none'})")
            g, _, sub = k.partition(".")
            if sub:
                nested[g][sub] = v
            else:
                top[k] = v
        return cls(**top, **{g: d for g, d in nested.items() if d})

    def to_dict(self) -> dict:
        """Flat: every parameter by name, a grouped one as ``group.name``."""
        out = {}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if "group" in f.metadata:
                out.update({f"{f.name}.{n}": getattr(v, n) for n in _exposed(f)})
            else:
                out[f.name] = v
        return out

    @classmethod
    def field_names(cls) -> tuple:
        out = []
        for f in dataclasses.fields(cls):
            out += [f"{f.name}.{n}" for n in _exposed(f)] if "group" in f.metadata else [f.name]
        return tuple(out)

    @classmethod
    def table(cls) -> str:
        """A text table of the parameters by group: name, default, paper value, range, description; then
        the earlier names."""
        def row(name, default, md, choices=None, paper=None, indent="  "):
            choices = choices if choices is not None else md.get("choices")
            rng = (f"{list(choices)}" if choices else
                   f"[{md.get('lo', '')}, {md.get('hi', '')}]" if md.get("lo") is not None or md.get("hi") is not None
                   else "")
            paper = md.get("paper") if paper is None else paper
            paper = "" if paper is None else f" (paper: {paper})"
            return f"{indent}{name:<24} = {default!r:<10} {rng:<18} {md.get('doc', '')}{paper}"

        rows, grouped = [], []
        for f in dataclasses.fields(cls):
            md = f.metadata
            if "group" not in md:
                rows.append(row(f.name, f.default, md))
                continue
            gcls, gdef = md["group"], f.default_factory()
            lines = [f"  {f.name}: {md['doc']}"]
            gfields = {g.name: g for g in dataclasses.fields(gcls)}
            for n in _exposed(f):
                lines.append(row(f"{f.name}.{n}", getattr(gdef, n), gfields[n].metadata, md["choices"].get(n),
                                 md["paper_values"].get(n), indent="    "))
            grouped += lines
        out = rows + grouped
        if cls.renamed:
            out.append("  earlier names: " + ", ".join(f"{k} -> {v}" for k, v in cls.renamed.items()))
        return "\n".join(out)


def _exposed(f) -> tuple:
    """The parameter names a group field ``f`` lets a suite set."""
    md = f.metadata
    return tuple(md["expose"]) if md["expose"] is not None else tuple(g.name for g in dataclasses.fields(md["group"]))


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
    """What one frame renders: the camera, the image size and the run's seed (``--seed``; 0 by default)."""

    camera: Camera
    width: int
    height: int
    seed: int = 0

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
    run_seed: int = 0  # the run's --seed, set by the runner before setup (View.seed carries it too)

    def __init__(self, params: ParamsBase | None = None):
        self.params = params if params is not None else self.Params()

    def seed_for(self, own: int = 0, bits: int = 32) -> int:
        """The seed a sampling method uses: its own ``seed`` parameter mixed with the run's seed,
        ``(own + run_seed · 0x9E3779B9) mod 2^bits``; at run seed 0 exactly ``own`` (results unchanged)."""
        return (int(own) + int(self.run_seed) * 0x9E3779B9) % (1 << bits)

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
        """``name`` beside the module of this class, else beside a base class's (a subclass elsewhere,
        e.g. a plugin deriving from an adapter, finds its parent's shaders)."""
        first = None
        for cls in type(self).__mro__:
            f = getattr(importlib.import_module(cls.__module__), "__file__", None) if cls.__module__ else None
            if f:
                p = Path(f).parent / name
                first = first or p
                if p.is_file():
                    return p
        return first


def registry() -> dict:
    """{name: Method subclass}: every adapter package under ``methods/`` (discovered), every entry point
    of group ``ldbench.methods``, and the ``package.module:Class`` references registered in this process
    or its driver (:mod:`harness.plugins`). Two classes with one name are one error naming both."""
    from harness import plugins

    package = __name__.rpartition(".")[0]  # the methods package, whatever it is installed as
    found, sources = {}, {}
    for mod in pkgutil.iter_modules([str(Path(__file__).parent)]):
        if not mod.ispkg:
            continue
        m = importlib.import_module(f"{package}.{mod.name}")
        for obj in vars(m).values():
            if isinstance(obj, type) and issubclass(obj, Method) and obj is not Method and obj.name:
                plugins.add_unique(found, sources, obj, f"{obj.__module__}.{obj.__qualname__} (ldbench)", "method")
    for obj, source in plugins.entry_point_classes(plugins.METHOD_GROUP, Method):
        plugins.add_unique(found, sources, obj, source, "method")
    for ref, path in plugins.references(plugins.METHOD_GROUP):
        obj = plugins.load_reference(ref, Method, path)
        plugins.add_unique(found, sources, obj, f"{ref} (--method)", "method")
    return dict(sorted(found.items()))


def aliases() -> dict:
    """{alias: canonical name} of every adapter that declares ``aliases`` (earlier names)."""
    return {a: name for name, cls in registry().items() for a in getattr(cls, "aliases", ())}


def canonical_name(name: str) -> str:
    """The registered name of a method given by name or alias (unknown names are returned as given);
    a ``package.module:Class`` reference is imported, registered (:mod:`harness.plugins`) and named."""
    from harness import plugins

    if plugins.is_reference(name):
        return plugins.register_reference(name, Method).name
    return aliases().get(name, name)


def get_method(name: str) -> type:
    from harness import plugins

    if plugins.is_reference(name):
        name = canonical_name(name)
    reg = registry()
    name = canonical_name(name)
    if name not in reg:
        raise LdbenchError(f"unknown method {name!r} (known: {', '.join(reg) or 'none'})")
    return reg[name]
