"""The colour of each method in every figure: fixed for the built-in methods, a hash of the name for any
other, so that a method keeps its colour from one report to the next."""
from __future__ import annotations

import zlib

from .plotting import colormap

#: Each built-in method's colour in every report (tab20's entries), so that a method is the same colour
#: from one run's figures to the next; the reference oracle is black.
METHOD_COLOURS = {"ldm": 0, "ldm-ao": 0, "ldi": 2, "cdi-vpl": 4, "ll-oit": 6, "hbao": 8, "gtao": 10,
                  "wboit": 12, "mlab": 14, "depth-peeling": 16, "dual-depth-peeling": 18, "alpha-blend": 1,
                  "direct-raster": 3, "external": 15, "mc-ao": 5}


def method_colours(methods) -> dict:
    """{method: colour}: the fixed colour of a built-in method (:data:`METHOD_COLOURS`), and for any other
    (a plugin, an external renderer) one of tab20's colours picked by a hash of its name, so it too keeps its
    colour across reports; ``oracle (Mitsuba)`` is black."""
    cm = colormap("tab20")
    out = {}
    for m in methods:
        if m == "oracle (Mitsuba)":
            out[m] = (0.0, 0.0, 0.0, 1.0)
        else:
            i = METHOD_COLOURS.get(m)
            out[m] = cm(i if i is not None else zlib.crc32(str(m).encode()) % 20)
    return out
