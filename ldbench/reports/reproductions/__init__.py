"""The papers' published tables and figures as data: one module per paper (``aalund2015.py``, ...).

Each module defines ``REPRODUCTIONS``, a tuple of :class:`ldbench.reports.reproduce.Reproduction` entries, and
nothing else that the engine reads; :func:`ldbench.reports.reproduce.registry` finds every module here
(modules whose name starts with ``_`` are skipped). See :mod:`ldbench.reports.reproduce` for how to add a paper.
"""
