"""Layered depth structures: one spec, one Python API and one GLSL access interface for every layout.

The seed methods are ray tracers over rasterized layered depth structures: ``layers`` images of
``width × height`` texels, each texel holding the depths (and payload words) of *every* surface its
centre sees along the layer's projection. A :class:`~ldbench.methods.structures.spec.StructureSpec` says which
structure, in one vocabulary:

==============  ===========================================================  ==============================
field           values                                                       module
==============  ===========================================================  ==============================
``layout``      ``linked``: per-texel linked lists, head image + node pool   :mod:`~.linked`
                (lock-free sorted insert, or yang2010 insert + sort);
                ``linear``: linearised arrays, count → GPU prefix sum →      :mod:`~.linear`
                fill → per-list sort (archer2019); compacted depth-peeled
                layers (niessner2010) are ``linear`` from the ``peel`` source
``source``      ``raster`` | ``one_pass`` | ``splat`` | ``peel``             :mod:`~.sources`,
                                                                             :mod:`~.splat`, :mod:`~.peel`
``assembly``    ``direct`` | ``sort`` (linear)                               :mod:`~.linear`
``pool``        ``grow`` | ``count`` (linked) | ``fixed`` | ``lazy``, with   the layouts
                ``pool_capacity``
==============  ===========================================================  ==============================

and the knobs of one layout or source (``sorted_insert``, ``max_list``, ``instanced``, ``aggregate``,
``indexed``, ``payload``, ``pass_layers``, ``raster_size``, ``splat_max``, ``splat_batch``,
``splat_group``, ``splat_large``, ``max_layers``, ``canonical``, ``page_nodes``). :func:`make_structure` builds it.
Every fragment pass of every layout and assembly runs the chosen source.

**GLSL** (``ldbench/methods/glsl/layered/layered.glsl``, compiled with ``structure.defines()``): ``ls_list(layer, px,
size)``, ``ls_first(list)``, ``ls_next(list, node)``, ``ls_depth(node)``, ``ls_payload(node, k)``,
``ls_bound()``, ``ls_count(list)``. A tracer written against it reads every layout.

Imports go one way: :mod:`~.spec` → :mod:`~.core` → the layouts (:mod:`~.linked`, :mod:`~.linear`) →
the sources (:mod:`~.sources`, :mod:`~.splat`, :mod:`~.peel`) → :mod:`~.factory`.
"""
from .core import LayeredStructure, bind_ortho_layers, bounding_sphere, fill_uint, ortho_layers
from .factory import make_structure
from .spec import ASSEMBLIES, LAYOUTS, PAYLOAD_WORDS, POOLS, SOURCES, StructureSpec

__all__ = ["ASSEMBLIES", "LAYOUTS", "PAYLOAD_WORDS", "POOLS", "SOURCES", "LayeredStructure", "StructureSpec",
           "bind_ortho_layers", "bounding_sphere", "fill_uint", "make_structure", "ortho_layers"]
