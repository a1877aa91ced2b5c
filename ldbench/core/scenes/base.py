"""The scene contract: a scene is one module of ``ldbench/core/scenes/`` (or an entry point of group
``ldbench.scenes``) that defines a :class:`SceneBuilder` subclass with a ``name``, a validated ``Params``
dataclass and a :meth:`~SceneBuilder.build` method; :func:`ldbench.core.scenes.builders` discovers them.

``Params`` derive from :class:`SceneParams`, the :class:`~ldbench.core.params.ParamsBase` of methods and
effects (fields declared with :func:`~ldbench.core.params.param`, checked on construction), which also reads
the spellings a scene parameter arrives in from TOML or the command line: an integer written as ``2e4`` or
``20000.0``, a path object, and colours (:func:`rgb`) as one or three numbers or a ``"r, g, b"`` text.
Shared pieces of the built-in scenes (the Cornell albedos, :func:`part_mesh`) live here too.
"""
from __future__ import annotations

import dataclasses
import math
import numbers
import os
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from ldbench.core.errors import LdbenchError
from ldbench.core.params import ParamsBase
from ldbench.core.scene import Mesh, Scene

# Cornell box albedos (linear RGB; the values of Bitterli's / the PBRT-v3 Cornell box), shared by the
# ``cornell`` box and the open box of the ``mesh`` scene.
WHITE = (0.725, 0.71, 0.68)
RED = (0.63, 0.065, 0.05)
GREEN = (0.14, 0.45, 0.091)


def rgb(default, doc: str):
    """A colour parameter: three numbers in [0, 1] (a tuple); given as 1 number (grey), 3 numbers, or the
    text ``"r, g, b"`` (``--scene-set albedo=0.7,0.6,0.5``)."""
    return field(default=tuple(float(x) for x in default),
                 metadata={"doc": doc, "lo": None, "hi": None, "choices": None, "paper": None, "rgb": True})


@dataclass(frozen=True)
class SceneParams(ParamsBase):
    """Base of a scene's ``Params``: :class:`~ldbench.core.params.ParamsBase` after reading the spellings
    a scene parameter may come in (an integral number for an ``int`` field, a path for a ``str`` field, a
    colour for an :func:`rgb` field)."""

    def __post_init__(self):
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if f.metadata.get("rgb"):
                v = rgb_value(self.prefix + f.name, v)
            elif type(f.default) is int:
                v = _integral(v)
            elif type(f.default) is str and isinstance(v, os.PathLike):
                v = os.fspath(v)
            object.__setattr__(self, f.name, v)
        super().__post_init__()


def _integral(v):
    """``v`` as an int when it is an integral number or its text (``20000``, ``2e4``, ``"20_000"``,
    ``20000.0``); anything else unchanged, for :class:`ParamsBase` to reject by name."""
    if isinstance(v, (bool, np.bool_)):
        return v
    if isinstance(v, str):
        text = v.strip().replace("_", "")
        try:
            return int(text)
        except ValueError:
            pass
        try:
            x = float(text)
        except ValueError:
            return v
    elif isinstance(v, numbers.Integral):
        return int(v)
    elif isinstance(v, numbers.Real):
        x = float(v)
    else:
        return v
    return int(x) if math.isfinite(x) and x.is_integer() else v


def rgb_value(name: str, value) -> tuple:
    """``value`` (1 or 3 numbers, or their text separated by commas or spaces) as an (r, g, b) tuple of
    floats in [0, 1]; otherwise one :class:`LdbenchError` line naming the parameter."""
    try:
        if isinstance(value, str):
            vals = [float(x) for x in value.replace(",", " ").split()]
        elif isinstance(value, numbers.Real):
            vals = [float(value)]
        else:
            vals = [float(x) for x in value]
        if len(vals) == 1:
            vals = vals * 3
        if len(vals) != 3 or not all(math.isfinite(x) for x in vals):
            raise ValueError
    except (TypeError, ValueError):
        raise LdbenchError(f"parameter {name} must be 1 or 3 numbers in [0, 1], got {value!r}") from None
    if min(vals) < 0 or max(vals) > 1:
        raise LdbenchError(f"parameter {name}={tuple(vals)} outside [0, 1]")
    return tuple(vals)


def part_mesh(name: str, part, albedo, opacity: float = 1.0) -> Mesh:
    """A :class:`~ldbench.core.scene.Mesh` of a :mod:`~ldbench.core.meshio` part ``(vertices, faces)``,
    as float32 vertices and int32 faces."""
    v, f = part
    return Mesh(name, v.astype(np.float32), f.astype(np.int32), albedo, opacity)


class SceneBuilder:
    """Base class of a scene. A subclass sets :attr:`name` and :attr:`Params` and implements :meth:`build`;
    its docstring describes the scene (its first sentence is the line ``ldbench scenes`` shows).

    The dispatcher (:func:`ldbench.core.scenes.load_scene`) validates the user's parameters into ``Params``
    (an unknown or out-of-range one is one error line naming the scene and the parameter), calls
    :meth:`build` and records the parameters used, defaults included, in ``scene.params`` (so
    ``load_scene(name, **scene.params)`` builds the same scene again). A build is deterministic.
    """

    #: the scene's name (``--scene NAME``, ``scene = "NAME"`` in a suite)
    name: ClassVar[str] = ""
    #: the validated parameters (a frozen dataclass deriving from :class:`SceneParams`)
    Params: ClassVar[type] = SceneParams
    #: the registered real scene the build reads from the scene cache ("" when none): it must be fetched first
    registered: ClassVar[str] = ""

    def build(self, p) -> Scene:
        """The scene for the validated parameters ``p`` (an instance of :attr:`Params`): meshes, a camera
        and the lights. Bad input beyond the parameters' declared ranges (an unreadable file) raises
        :class:`~ldbench.core.errors.LdbenchError`."""
        raise NotImplementedError
