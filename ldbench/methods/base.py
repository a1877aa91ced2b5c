"""The method-adapter contract (docs/design.md, "Method adapter contract") and the adapter registry.

An adapter is a sub-package ``ldbench/methods/<folder>/`` whose ``__init__.py`` defines a :class:`Method`
subclass with ``name``, ``paper``, ``effects`` and a ``Params`` dataclass. Adapters are discovered by
:func:`registry` (every sub-package that defines one), never listed by hand.

Params are frozen dataclasses deriving from :class:`ParamsBase`; each field is declared with
:func:`param` (default, documentation, range or choices) and validated on construction, so an unknown
or out-of-range value is one clear error naming the parameter.
"""
from __future__ import annotations

import importlib
import pkgutil
from dataclasses import dataclass, field
from pathlib import Path
from types import SimpleNamespace
from typing import TYPE_CHECKING, Callable

import numpy as np

from ldbench.core import plugins
from ldbench.core.errors import LdbenchError
from ldbench.core.scene import Camera, Scene
from ldbench.core.params import ParamsBase, group, param  # noqa: F401 (re-exported)
from ldbench.methods.gbuffer import GBuffer, SceneGeometry

if TYPE_CHECKING:
    from ldbench.core.effects.rays import RayBatch


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

    image: np.ndarray | Callable[[], np.ndarray] | None = None
    memory_bytes: dict = field(default_factory=dict)
    counters: dict = field(default_factory=dict)
    stages_ms: dict = field(default_factory=dict)
    mask: np.ndarray | Callable[[], np.ndarray] | None = None
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
    Params: type[ParamsBase] = ParamsBase
    folder: Path = Path(__file__).parent
    #: the exact ray tracer ``t = oracle(scene, batch)`` (a :class:`~ldbench.core.effects.rays.RayBatch`; inf =
    #: miss), set by the harness for adapters whose parameters ask for an exact baseline (never timed)
    oracle: Callable[[Scene, RayBatch], np.ndarray] | None = None
    #: the exact primary hits, RSM hits and ray epsilons (``primary_hits``, ``rsm_hits``, ``epsilons``), as the
    #: effects get them; set by the harness before setup
    exact: SimpleNamespace
    run_seed: int = 0  # the run's --seed, set by the runner before setup (View.seed carries it too)

    def __init__(self, params: ParamsBase | None = None):
        self.params: ParamsBase = params if params is not None else self.Params()

    def seed_for(self, own: int = 0, bits: int = 32) -> int:
        """The seed a sampling method uses: its own ``seed`` parameter mixed with the run's seed,
        ``(own + run_seed · 0x9E3779B9) mod 2^bits``; at run seed 0 exactly ``own`` (results unchanged)."""
        return (int(own) + int(self.run_seed) * 0x9E3779B9) % (1 << bits)

    def setup(self, gpu, scene) -> None:
        """Upload the scene and compile shaders; not timed."""
        raise NotImplementedError

    def frame(self, view: View, effect, inputs=None) -> Result:
        """Render one frame; wrap each stage in ``with gpu.stage(name):``. ``inputs`` are the effect's
        harness-built inputs (e.g. a :class:`~ldbench.core.effects.rays.RayBatch`, already uploaded), the
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

    def setup_scene(self, gpu, scene, gbuffer: str = "hardware") -> None:
        """The common part of ``setup``: ``self.res`` (memory-accounted allocations), the scene's
        triangles on the GPU (``self.geo``) and a G-buffer pass (``self.gbuf``, rasterized by ``gbuffer``:
        ``hardware`` or ``compute``, :class:`~ldbench.methods.gbuffer.GBuffer`)."""
        self.gpu, self.scene = gpu, scene
        self.res = gpu.resources()
        self.geo = SceneGeometry(gpu, scene, self.res)
        self.gbuf = GBuffer(gpu, self.geo, self.res, raster=gbuffer)

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
        assert first is not None  # Method's own module, in every class's MRO, is a file
        return first


#: {plugins.discovery_key: registry}: the current environment's only
_REGISTRY: dict[tuple, dict[str, type[Method]]] = {}


def registry() -> dict[str, type[Method]]:
    """{name: Method subclass}: every adapter package under ``methods/`` (discovered), every entry point
    of group ``ldbench.methods``, and the ``package.module:Class`` references registered in this process
    or its driver (:mod:`ldbench.core.plugins`). Two classes with one name are one error naming both."""
    key = plugins.discovery_key(plugins.METHOD_GROUP)
    if key not in _REGISTRY:
        reg = _discover()
        _REGISTRY.clear()
        _REGISTRY[key] = reg
    return dict(_REGISTRY[key])


def _discover() -> dict[str, type[Method]]:
    package = __name__.rpartition(".")[0]  # the methods package, whatever it is installed as
    found: dict[str, type[Method]] = {}
    sources: dict[str, str] = {}
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
    a ``package.module:Class`` reference is imported, registered (:mod:`ldbench.core.plugins`) and named."""
    if plugins.is_reference(name):
        return plugins.register_reference(name, Method).name
    return aliases().get(name, name)


def get_method(name: str) -> type[Method]:
    if plugins.is_reference(name):
        name = canonical_name(name)
    reg = registry()
    name = canonical_name(name)
    if name not in reg:
        raise LdbenchError(f"unknown method {name!r} (known: {', '.join(reg) or 'none'})")
    return reg[name]
