"""The effect contract: :class:`EffectSpec` (one subclass per module of this package) and :class:`Effect`.

An effect spec declares, as data and a few hooks:

=====================  ===========================================================================
``name``               the effect's name (``ao``, ``rays``, ...)
``Params``             a frozen :class:`~ldbench.core.params.ParamsBase` dataclass: its validated parameters
``output``             ``"image"``, ``"rays"`` or ``"vpls"``: what a method returns
``needs_light``        whether the definition involves the scene's light (:meth:`requires_light` may
                       refine it by parameter); :meth:`check_scene` is the one place that enforces it
``reference_key``      the key of its ground truth in the references' registry
                       (:data:`ldbench.references.registry.RENDERERS`; the harness wires the two), or
``render_reference()`` the effect's own ground truth, for an effect whose reference no renderer there makes
                       (a new effect then brings its ground truth in its own module)
``reference_backend``  the ground truth, in words (Mitsuba 3 integrator or oracle)
``metrics``            the result columns the effect's tables show
``columns``            every result column the effect fills, with its type (``float``, ``int``, ``str``,
                       ``json``): the results schema is the harness's columns plus these
                       (:func:`effect_columns`)
``units``              what its values are, in words (figure and viewer captions)
``answer_key``         (non-image effects) the array an answer must hold (``ldbench score``)
``figures``            the report's figures of this effect beyond those of every effect (``"rays"``:
                       accuracy against rays per second)
``gate``               (non-image effects) the metrics the nightly gate checks: (column, "higher"|"lower"
                       is better, absolute tolerance, relative tolerance); image effects are gated on
                       PSNR/SSIM against their reference's noise (:mod:`ldbench.harness.compare`)
``supersedes``         effect parameters that replace a method's parameter of the same name on this
                       effect (the harness builds the inputs from them): the row records the effect's
``inputs()``           arrays the harness builds deterministically from (scene, view, seed) and hands
                       identically to the method and to the reference (None for pure image effects),
                       from the exact geometry the harness passes in (``exact``, below)
``input_bytes()``      the peak host memory of those inputs for a size, checked before any work
``score()``            the metric columns of one method result against the reference
``save()``             images of the result, the reference and the error, for reports
``noise()``            the reference's own noise (``rms_std_of_mean``, ``spp``), for the nightly gate
``export_arrays()``    (non-image effects) the inputs ``ldbench export`` writes as ``batch.npz``, with their
                       description
``answer_arrays()``    (non-image effects) inputs and answers as ``run --save-arrays`` writes them
``caption()``          the report grid's lines of headline metrics under a result's image
``error_label()``      what the report's error map shows, in words
=====================  ===========================================================================

:class:`ImageEffect` implements the image effects (``ao``, ``direct``, ``indirect``): Mitsuba 3 reference
images with per-pixel variance (``reference_key`` "image": :func:`ldbench.references.render_reference`),
PSNR/SSIM/FLIP/relMSE and coverage.

This package imports nothing above the foundation: a spec names its reference by key, and the inputs of
the effects that need exact geometry (``rays``, ``vpl_range``) are built from ``exact``, an object the
harness hands in with ``primary_hits(scene, width, height)`` and ``rsm_hits(scene, R)`` (dicts of
``mask``, ``position``, ``normal``, ...) and ``epsilons()`` (the ray and shadow epsilons of the ground
truth); :data:`ldbench.references.registry.EXACT` is the Mitsuba 3 one.
"""
from __future__ import annotations

import importlib
import math
import pkgutil
from pathlib import Path

import numpy as np

from ldbench.core import metrics, plugins
from ldbench.core.errors import LdbenchError
from ldbench.core.imageio import save_image, save_map
from ldbench.core.params import ParamsBase

#: Image metrics (columns of the records).
IMAGE_METRICS = ("psnr", "ssim", "flip", "relmse", "coverage")
#: Every column an image effect fills, with its type.
IMAGE_COLUMNS = {"psnr": "float", "ssim": "float", "flip": "float", "relmse": "float", "coverage": "float",
                 "nonfinite": "int"}


class EffectSpec:
    """Base class of an effect specification (see the module docstring)."""

    name: str = ""
    Params: type[ParamsBase]  # every spec sets its own
    output: str = "image"
    needs_light: bool = False
    reference_key: str = ""
    reference_backend: str = ""
    metrics: tuple = ()
    columns: dict = {}
    units: str = ""
    answer_key: str = ""
    figures: tuple = ()
    gate: tuple = ()
    supersedes: tuple = ()

    # ---- identity -----------------------------------------------------------------------------------
    def key(self, params) -> dict:
        """JSON-able description of the effect with its parameters (cache keys, records)."""
        out = {"effect": self.name}
        for k, v in params.to_dict().items():
            out[k] = "inf" if isinstance(v, float) and math.isinf(v) else v
        return out

    def label(self, params) -> str:
        """Short file-name form, e.g. ``ao-step-dinf`` or ``rays-diffuse-4``."""
        return self.name

    def text(self, params) -> str:
        """The effect as tables, figures and ``compare`` write it: ``rays (diffuse, rays_per_pixel = 4)``:
        the name, then each parameter of :meth:`key` (a text value bare, a number with its name; ∞ for inf)."""
        rest = [(k, v) for k, v in self.key(params).items() if k != "effect"]
        if not rest:
            return self.name
        return f"{self.name} (" + ", ".join(v if isinstance(v, str) and v != "inf" else f"{k} = {_fmt(v)}"
                                            for k, v in rest) + ")"

    # ---- scene and inputs ---------------------------------------------------------------------------
    def requires_light(self, params) -> bool:
        return self.needs_light

    def check_scene(self, scene, params) -> None:
        """The one place that decides whether the scene can show this effect (e.g. it has a light)."""
        if self.requires_light(params) and not scene.lights:
            raise LdbenchError(f"scene {scene.name!r} has no spot or point light; effect {self.name!r} needs one")

    def stochastic(self, params) -> bool:
        """Whether the reference is a Monte Carlo estimate (then ``spp`` matters)."""
        return True

    def inputs(self, scene, width: int, height: int, params, seed: int, exact=None):
        """Harness-built inputs handed to both the method and the reference (None: none); ``exact`` is
        the exact geometry they are built from (module docstring)."""
        return None

    def input_bytes(self, params, width: int, height: int) -> int:
        """Host memory the inputs of this size may take at their peak (building, scoring, exporting them), an
        upper bound known before any work: every command checks it with the image's own against the memory
        available (:func:`ldbench.harness.suite.check_budget`). 0: no inputs."""
        return 0

    # ---- metrics, artefacts -------------------------------------------------------------------------
    def score(self, result, reference, *, scene, inputs, stage_ms: dict) -> dict:
        raise NotImplementedError

    def save(self, result, reference, inputs, folder, label: str, ref_label: str) -> dict:
        raise NotImplementedError

    def noise(self, reference) -> dict:
        """The reference's own noise, for the nightly gate's quality threshold."""
        raise NotImplementedError

    def error_label(self) -> str:
        """What the report's error map of this effect shows, in words (its colour bar's label)."""
        return f"|test − reference| ({self.units or 'values'}, mean over channels)"

    def caption(self, row, f) -> list:
        """The lines under a result's image in the report's grid: this effect's headline metrics of ``row``,
        each number written by ``f(value, digits)`` (none by default)."""
        return []

    def render_reference(self, scene, params, *, width: int, height: int, spp: int, seed: int, inputs, exact):
        """The ground truth of this effect, made by the effect itself (``exact``: the exact geometry of the
        module docstring); a spec that defines it is answered by it, whatever its ``reference_key``."""
        raise NotImplementedError

    def export_arrays(self, inputs, width: int, height: int) -> tuple[dict, str] | None:
        """({name: array}, what they are in words) of the inputs ``ldbench export`` writes as ``batch.npz``
        (None: the effect has none beyond the scene, camera and lights)."""
        return None

    def answer_arrays(self, result, reference, inputs) -> dict | None:
        """{name: array} of one result's inputs and answers as ``run --save-arrays`` writes them (None: an
        image effect, whose images are saved instead)."""
        return None

    def problems(self, scores: dict) -> list:
        """Why a scored result is not ``ok`` (one line each; the row becomes ``degraded: ...``): answers
        that were NaN or ±inf where the format gives them no meaning (the ``nonfinite`` column), which the
        metrics count as failed, as a missing answer."""
        n = int(scores.get("nonfinite") or 0)
        return [f"{n} non-finite {'pixels' if self.output == 'image' else 'answers'}"] if n else []


class ImageEffect(EffectSpec):
    """An effect whose output is an image compared against a Mitsuba 3 reference image.

    ``channels`` (1 for AO, 3 for radiance), ``background`` (the value of pixels where the camera sees
    nothing, also what a method's *missing* pixel is taken to show) and ``data_range`` (the PSNR/SSIM
    peak; None = the reference's maximum over valid pixels) complete the declaration.
    """

    output = "image"
    channels = 3
    units = "linear radiance"
    background = 0.0
    data_range: float | None = None
    reference_key = "image"
    reference_backend = "Mitsuba 3, ldbench.references.render_reference"
    metrics = IMAGE_METRICS
    columns = IMAGE_COLUMNS

    def caption(self, row, f):
        return [f"PSNR {f(row['psnr'], 2)} dB · SSIM {f(row['ssim'], 3)}",
                f"FLIP {f(row['flip'], 3)} · relMSE {f(row['relmse'], 4)}"]

    def method_image(self, result, reference):
        """(image, coverage mask): the method's image with its missing pixels set to ``background``, so
        that a hole counts as error wherever the reference sees a surface. A pixel is missing where the
        mask is False, zero or not finite, and where the image is not finite in some channel (NaN, ±inf:
        a failed pixel, counted by :meth:`nonfinite`)."""
        img, covered, _ = self._coverage(result, reference)
        return np.where(covered[..., None], img, np.float32(self.background)), covered

    def nonfinite(self, result, reference) -> int:
        """Pixels the method claims (mask True, or no mask) whose value is NaN or ±inf, plus pixels whose
        mask value is NaN or ±inf: failed pixels, the row's ``nonfinite`` column."""
        return self._coverage(result, reference)[2]

    def _coverage(self, result, reference):
        with np.errstate(over="ignore", invalid="ignore"):  # float64 beyond float32's range: inf, counted
            img = np.asarray(result.image, np.float32)
        if img.ndim == 2:
            img = img[..., None]
        if img.shape != reference.mean.shape:
            raise LdbenchError(f"a method returned an image of shape {img.shape}, the reference has "
                               f"{reference.mean.shape}")
        finite = np.isfinite(img).all(-1)
        if result.mask is None:
            covered, bad_mask = np.ones(img.shape[:2], bool), np.zeros(img.shape[:2], bool)
        else:
            m = np.asarray(result.mask)
            if m.ndim == 3 and m.shape[-1] == 1:
                m = m[..., 0]
            if m.shape != img.shape[:2]:
                raise LdbenchError(f"a method returned a mask of shape {m.shape}, the image is {img.shape[:2]}")
            if m.dtype.kind not in "biuf":
                raise LdbenchError(f"a method returned a mask of dtype {m.dtype}; masks are bool or numbers")
            bad_mask = ~np.isfinite(m) if m.dtype.kind == "f" else np.zeros(m.shape, bool)
            covered = (m != 0) & ~bad_mask
        nonfinite = int(np.count_nonzero((covered & ~finite) | bad_mask))
        return img, covered & finite, nonfinite

    def score(self, result, reference, *, scene, inputs, stage_ms):
        img, covered = self.method_image(result, reference)
        mask = reference.mask
        if not mask.any():
            raise LdbenchError(f"scene {scene.name!r}: the camera sees no geometry, nothing to compare")
        m = metrics.all_metrics(img, reference.mean, mask=mask, data_range=self.data_range)
        m["coverage"] = float(covered[mask].mean())
        m["nonfinite"] = self.nonfinite(result, reference)
        m["metric_settings"]["coverage"] = "fraction of reference-hit pixels the method gave a finite value; " \
                                           f"missing and non-finite pixels count as error with value {self.background:g}"
        return m

    def preview_scale(self, reference):
        """The value shown as white in PNG previews (None: 1)."""
        if self.channels == 1:
            return None
        return float(np.percentile(reference.mean[reference.mask], 99) or 1.0) if reference.mask.any() else 1.0

    def save(self, result, reference, inputs, folder, label, ref_label):
        img, _ = self.method_image(result, reference)
        scale = self.preview_scale(reference)
        if not (folder / f"{ref_label}.exr").exists():
            save_image(folder / ref_label, reference.mean, png_scale=scale)
        save_image(folder / label, img, png_scale=scale)
        emap = metrics.error_map(img, reference.mean, mask=reference.mask)
        vmax = save_map(folder / f"{label}-error", emap, reference.mask)
        return {"image": f"{label}.png", "exr": f"{label}.exr", "error_exr": f"{label}-error.exr",
                "reference": f"{ref_label}.png", "error_vmax": vmax}

    def noise(self, reference) -> dict:
        """The reference's own noise, for the nightly gate's quality threshold."""
        m = reference.mask
        rms = float(np.sqrt(np.mean(reference.variance[m]))) if m.any() else 0.0
        return {"rms_std_of_mean": rms, "spp": reference.meta.get("spp")}


# --------------------------------------------------------------------------------------------------
# registry and values

_REGISTRY: dict | None = None


def _in_tree() -> list:
    """The spec classes of this package's effect modules (discovered, module order)."""
    package = __name__.rpartition(".")[0]  # this package, whatever it is installed as
    out = []
    for mod in pkgutil.iter_modules([str(Path(__file__).parent)]):
        if mod.name.startswith("_") or mod.name == "base":
            continue
        m = importlib.import_module(f"{package}.{mod.name}")
        out += [obj for obj in vars(m).values() if isinstance(obj, type) and issubclass(obj, EffectSpec)
                and obj.name and obj.__module__ == m.__name__]
    return out


def registry() -> dict:
    """{name: spec instance} for every effect module of this package (discovered) and every entry point
    of group ``ldbench.effects`` (:mod:`ldbench.core.plugins`); two specs with one name are one error."""
    global _REGISTRY
    if _REGISTRY is None:
        found: dict[str, type[EffectSpec]] = {}
        sources: dict[str, str] = {}
        for obj in _in_tree():
            plugins.add_unique(found, sources, obj, f"{obj.__module__}.{obj.__qualname__} (ldbench)", "effect")
        for obj, source in plugins.entry_point_classes(plugins.EFFECT_GROUP, EffectSpec):
            plugins.add_unique(found, sources, obj, source, "effect")
        _REGISTRY = {name: cls() for name, cls in sorted(found.items())}
    return _REGISTRY


def effect_columns(specs=None) -> dict:
    """{column: type} of every column the effects fill, in the order of ``specs`` (default: the effects of
    this package, by name) and of each one's ``columns``; a column two effects type differently is an error.
    The in-tree effects make the results schema (:data:`ldbench.harness.records.COLUMN_TYPES`), so that it
    does not change with what is installed; a plugin effect's own columns are kept as extra columns
    (:func:`ldbench.harness.records.make_row`)."""
    if specs is None:
        specs = sorted(_in_tree(), key=lambda c: c.name)
    out: dict = {}
    for spec in specs:
        for col, kind in spec.columns.items():
            if out.setdefault(col, kind) != kind:
                raise TypeError(f"effect {spec.name!r} types column {col!r} as {kind!r}, another as {out[col]!r}")
    return out


def effect_units(name: str) -> str:
    """The units of effect ``name``'s values, in words, for captions ("values" for an effect not installed:
    a run written where a plugin effect was, read where it is not)."""
    spec = registry().get(str(name))
    return spec.units if spec is not None and spec.units else "values"


def get_spec(name: str) -> EffectSpec:
    reg = registry()
    if name not in reg:
        raise LdbenchError(f"unknown effect {name!r} (known: {', '.join(reg)})")
    return reg[name]


class Effect:
    """An effect value: ``Effect("ao", d_max=0.5, falloff="quadratic")``, ``Effect("rays", ray_kind="shadow")``.

    Parameters are the spec's ``Params`` fields (positional in field order, or by name), validated on
    construction. Parameter values read as attributes (``effect.d_max``). Equal effects hash equally.
    """

    __slots__ = ("name", "spec", "params")

    def __init__(self, name: str, *args, **kwargs):
        spec = get_spec(name)
        fields = spec.Params.field_names()
        unknown = set(kwargs) - set(fields)
        if unknown:
            raise LdbenchError(f"unknown effect parameter {sorted(unknown)[0]!r} for effect {name!r}"
                               + (f" (known: {', '.join(fields)})" if fields else " (it takes none)"))
        if len(args) > len(fields):
            raise LdbenchError(f"effect {name!r} takes at most {len(fields)} parameters")
        object.__setattr__(self, "name", name)
        object.__setattr__(self, "spec", spec)
        object.__setattr__(self, "params", spec.Params(*args, **kwargs))

    @classmethod
    def parse(cls, name: str, params: dict | None = None) -> "Effect":
        """From a name and a dict of parameters (strings such as ``"inf"`` are accepted where declared)."""
        return cls(name, **dict(params or {}))

    def __getattr__(self, k):
        if k in ("name", "spec", "params"):  # not yet set (unpickling)
            raise AttributeError(k)
        try:
            return getattr(self.params, k)
        except AttributeError:
            raise AttributeError(f"effect {self.name!r} has no parameter {k!r}") from None

    def __setattr__(self, k, v):
        raise AttributeError("Effect is immutable")

    def __reduce__(self):
        return (_rebuild, (self.name, self.params.to_dict()))

    def __eq__(self, other):
        return isinstance(other, Effect) and (self.name, self.params) == (other.name, other.params)

    def __hash__(self):
        return hash((self.name, self.params))

    def __repr__(self):
        ps = ", ".join(f"{k}={v!r}" for k, v in self.params.to_dict().items())
        return f"Effect({self.name!r}{', ' if ps else ''}{ps})"

    def key(self) -> dict:
        return self.spec.key(self.params)

    def label(self) -> str:
        return self.spec.label(self.params)

    def text(self) -> str:
        return self.spec.text(self.params)

    def check_scene(self, scene) -> None:
        self.spec.check_scene(scene, self.params)

    def needs_light(self) -> bool:
        return self.spec.requires_light(self.params)


def _rebuild(name, params):
    return Effect(name, **params)


def effects_from_user(name: str, combos: list) -> list:
    """The effects of parameters a user gave (the command line: one dict; a suite's sweep: one dict per
    combination), under one rule: every parameter given must be one the effect uses, with at least one
    of the values it is swept over, else one line naming the effect's parameters. An effect uses what
    its :meth:`EffectSpec.key` records (the key identifies its result: a parameter missing from it
    changes nothing), so ``--d-max`` on ``rays`` of kind diffuse is refused like ``--ray-kind`` on ``ao``."""
    spec = get_spec(name)
    fields = spec.Params.field_names()
    combos = [dict(c) for c in combos] or [{}]
    known = f"its parameters: {', '.join(fields)}" if fields else "it takes none"
    for k in sorted(set().union(*combos)):
        if k not in fields:
            raise LdbenchError(f"effect {name!r} does not use parameter {k!r} ({known})")
    effects = [Effect(name, **c) for c in combos]
    for k in sorted(set().union(*combos)):
        if not any(k in e.key() for e in effects):
            uses = sorted({u for e in effects for u in e.key() if u != "effect"}, key=fields.index)
            with_ = ", ".join(f"{o}={v!r}" for o, v in sorted({(o, c[o]) for c in combos for o in c if o != k}))
            raise LdbenchError(f"effect {name!r}{' with ' + with_ if with_ else ''} does not use parameter {k!r} "
                               f"(it uses: {', '.join(uses) or 'none'}; {known})")
    return effects


def _fmt(v) -> str:
    if v == "inf" or (isinstance(v, float) and math.isinf(v)):
        return "∞"
    return f"{v:g}" if isinstance(v, float) else str(v)


def effect_from_key(key: dict) -> Effect:
    """The :class:`Effect` of a record's ``effect_params`` (the inverse of :meth:`Effect.key`)."""
    d = dict(key)
    return Effect.parse(d.pop("effect"), d)
