"""What a row was measured on: the device class of a GL renderer and the machine columns of a row.

:func:`classify_device` is the one rule that decides how a run is timed (:class:`~ldbench.core.gpu.Gpu`:
GL timer queries, or wall clock on a software rasterizer) and what its rows record as ``device``
(:func:`~ldbench.harness.records.machine_info`), so the two can never disagree.

:data:`MACHINE_FIELDS` are the row columns that describe the machine, with their labels in reports;
:func:`timing_fields` are those that must agree for two rows' times to be comparable
(``ldbench compare``).
"""
from __future__ import annotations

#: Substrings (lower case) of the GL renderer or vendor of renderers that rasterize on the CPU: Mesa's
#: llvmpipe/softpipe/swrast ("Software Rasterizer"), Apple's "Apple Software Renderer", Google's
#: SwiftShader, Microsoft's WARP ("Microsoft Basic Render Driver") and GDI ("GDI Generic").
SOFTWARE_RENDERERS = ("llvmpipe", "softpipe", "swrast", "software", "swiftshader", "microsoft basic render",
                      "gdi generic")

#: (row column, label): the machine a row was measured on, as reports show it.
MACHINE_FIELDS = (("device", "device"), ("gl_renderer", "GL renderer"), ("gl_version", "GL version"),
                  ("driver", "driver"), ("cpu", "CPU"), ("gpu_name", "GPU"))

#: Machine columns that must agree for times to be comparable (``gl_version`` repeats the driver);
#: :func:`timing_fields` adds ``cpu`` where the CPU is the device.
TIMING_FIELDS = ("device", "gl_renderer", "driver", "gpu_name")


def timing_fields(*devices) -> tuple:
    """:data:`TIMING_FIELDS`, plus ``cpu`` when any of ``devices`` is ``cpu-software`` (llvmpipe's renderer
    string names the LLVM version, not the CPU that runs it)."""
    return TIMING_FIELDS + (("cpu",) if "cpu-software" in devices else ())


def classify_device(renderer: str | None, vendor: str | None = None) -> str | None:
    """Device class from the GL renderer and vendor strings.

    ``"cpu-software"`` when either names a software rasterizer (:data:`SOFTWARE_RENDERERS`; checked
    first: what rasterizes decides, whatever the vendor), else ``"nvidia"`` when either mentions NVIDIA,
    else ``"gpu"``; None when both are unknown. cpu-software runs are timed by wall clock (their timer
    queries are meaningless) and their timing claims are "not measurable here" (:mod:`ldbench.reports.reproduce`).
    """
    text = f"{renderer or ''} {vendor or ''}".lower()
    if not text.strip():
        return None
    if any(s in text for s in SOFTWARE_RENDERERS):
        return "cpu-software"
    if "nvidia" in text:
        return "nvidia"
    return "gpu"
