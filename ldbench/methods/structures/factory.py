"""One entry point: :func:`make_structure` builds the structure a :class:`StructureSpec` describes."""
from __future__ import annotations

from .linear import LinearisedArrays
from .linked import LayeredLinkedLists
from .peel import Peel
from .sources import FragmentSource, OnePass, Raster
from .spec import StructureSpec
from .splat import Splat

LAYOUT_CLASSES = {"linked": LayeredLinkedLists, "linear": LinearisedArrays}


def make_structure(spec: StructureSpec, gpu, geometry, res, *, layers: int, width: int,
                   height: int | None = None, prefix: str = "ls.", sphere=None):
    """The structure of ``spec`` with ``layers`` layers of ``width × height`` texels (``height``: default
    ``width``) over ``geometry`` (:class:`~ldbench.methods.gbuffer.SceneGeometry`), its buffers named ``prefix``…
    in ``res``. ``sphere`` = (centre, radius) the ``one_pass`` raster covers (default: the geometry's
    bounding sphere). The layers' transforms follow with ``set_layers``."""
    s = LAYOUT_CLASSES[spec.layout](gpu, geometry, res, spec, layers=layers, width=width, height=height,
                                    prefix=prefix)
    source: FragmentSource
    if spec.source == "raster":
        source = Raster(s)
    elif spec.source == "one_pass":
        source = OnePass(s, sphere)
    elif spec.source == "splat":
        source = Splat(s)
    else:
        source = Peel(s)
    return s.attach_source(source)
