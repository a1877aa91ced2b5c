"""The papers' published tables and figures as data: one folder per paper table.

A paper is a package (``aalund2015/``, ...) whose ``__init__.py`` holds what its tables share (the paper's
citation and set-up in its docstring, paper-wide constants and helpers, and ``TABLES``, the order in which
``ldbench reproduce --list`` shows its tables). Each table is a folder inside it, e.g. ``aalund2015/fig8/``:

* ``__init__.py`` defines ``REPRODUCTION``, one :class:`ldbench.reports.reproduce.Reproduction` whose key is the
  folder's, ``<paper>-<table>`` with ``_`` read as ``-`` (``aalund2015/fig8_real`` is ``aalund2015-fig8-real``);
* ``suite.toml`` is the suite that reproduces it, bundled under that key (``ldbench run aalund2015-fig8``).

So a new table is one new folder. :func:`ldbench.reports.reproduce.registry` finds every table (names starting
with ``_`` are skipped); docs/how-to/reproduce-a-paper-table.md says how to add one.
"""
