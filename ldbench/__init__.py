"""ldbench: a benchmark and validation suite for real-time global illumination through rasterized
layered depth structures.

The layers, lowest first; each imports only those before it (``tests/test_imports.py``):

- :mod:`ldbench.core`: errors, validated parameters, the GL context and its timing, scenes, effects,
  metrics, image I/O and conventions;
- :mod:`ldbench.methods`: the method adapters (GLSL through moderngl) and their registry;
- :mod:`ldbench.references`: the Mitsuba 3 ground truth and its cache;
- :mod:`ldbench.harness`: suites, jobs, executors, records and the ``ldbench`` command line;
- :mod:`ldbench.reports`: figures, the HTML/Markdown report and the paper reproductions.
"""
