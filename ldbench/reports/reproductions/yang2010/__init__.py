"""yang2010: Yang, Hensley, Grün, Thibieroz, "Real-Time Concurrent Linked List Construction on the GPU"
(EGSR 2010), Table 1 and the first-n-layers trade-off and the costs of §4.1.3 as data, one folder per table
(``table1``, ``costs``: its :class:`~ldbench.reports.reproduce.Reproduction` and its ``suite.toml``; the engine
is :mod:`ldbench.reports.reproduce`). This package holds what the tables share: fps as milliseconds, Fig. 4's
set-up and the hairball that stands in for the mecha.

Published frame rates are converted to milliseconds (1000 / fps) because the engine compares times; the
row labels keep the fps. Table 1 is "normalized to ATI Radeon HD 5770 performance" at 512×512; its dual
depth peeling and bucket depth peeling numbers were measured on a GTX 280 and scaled by 1/1.23. The
layer-cap numbers are the averages of Fig. 4(a) (mecha sequence, HD 5870, 1280×720).
"""
from __future__ import annotations


def ms(fps: float) -> float:
    """Frame time in ms of a published frame rate."""
    return round(1000.0 / fps, 3)


#: Fig. 4(a)'s set-up, where the layer cap and the costs were measured
F4 = "Fig. 4(a) average, mecha, HD 5870, 1280×720"
#: The hairball that stands in for the mecha (up to ~70 layers per pixel, like the mecha's 'almost 64')
HAIRBALL = {"triangles": 60000, "opacity": 0.3}

#: The order of the tables in `ldbench reproduce --list` (a table folder not named here follows, by name)
TABLES = ("table1", "costs")
