"""The papers' published tables and figures as data: one module per paper (``aalund2015.py``, ...).

Each module defines ``REPRODUCTIONS``, a tuple of :class:`harness.reproduce.Reproduction` entries, and
nothing else that the engine reads; :func:`harness.reproduce.registry` finds every module here
(modules whose name starts with ``_`` are skipped). See :mod:`harness.reproduce` for how to add a paper.
"""
