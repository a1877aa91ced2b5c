"""Which EGL device a process renders on: the GPU that CUDA (and so Ray and Dr.Jit) gave it.

EGL enumerates devices in its own order (``eglQueryDevicesEXT``), which is neither CUDA's nor
nvidia-smi's, and ``CUDA_VISIBLE_DEVICES`` does not change it. A process that was handed one GPU
through ``CUDA_VISIBLE_DEVICES`` (a Ray task with ``num_gpus=1``) therefore finds its GPU through the
``EGL_NV_device_cuda`` extension: ``eglQueryDeviceAttribEXT(dev, EGL_CUDA_DEVICE_NV)`` is the CUDA
ordinal of an EGL device *in this process's CUDA numbering*, so the EGL device whose ordinal is 0 is
the first GPU of ``CUDA_VISIBLE_DEVICES``. That is the device :func:`select` picks.

Selection rules (:func:`select`, a pure function of what was queried, tested with fakes):

* ``GLCONTEXT_DEVICE_INDEX`` set: that index (glcontext honours the variable itself; we only record it);
* no device answers ``EGL_CUDA_DEVICE_NV`` (Mesa, llvmpipe, no NVIDIA driver, ``CUDA_VISIBLE_DEVICES=""``):
  no choice, today's behaviour (glcontext's default, EGL device 0);
* otherwise the device whose CUDA ordinal is 0; none such: the default again.

The PCI bus id recorded with the choice comes from the EGL device itself where the driver says
(``EGL_EXT_device_persistent_id`` UUID, matched against nvidia-smi; or ``EGL_EXT_device_drm``'s
``/dev/dri/cardN`` through sysfs), else from the ``CUDA_VISIBLE_DEVICES`` GPU through nvidia-smi.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import os
import shutil
import subprocess
from dataclasses import dataclass

EGL_EXTENSIONS = 0x3055
EGL_CUDA_DEVICE_NV = 0x323A
EGL_DRM_DEVICE_FILE_EXT = 0x3233
EGL_DEVICE_UUID_EXT = 0x335C
EGL_RENDERER_EXT = 0x335F
_MAX_DEVICES = 32
_SMI_TIMEOUT_S = 10


@dataclass(frozen=True)
class EglDevice:
    """What EGL says about one device (None: the driver does not say)."""

    index: int
    extensions: str = ""
    cuda: int | None = None  # EGL_CUDA_DEVICE_NV: CUDA ordinal in this process's numbering
    uuid: str | None = None  # "GPU-xxxxxxxx-xxxx-xxxx-xxxx-xxxxxxxxxxxx" (nvidia-smi's form)
    drm: str | None = None  # /dev/dri/cardN
    renderer: str | None = None


@dataclass(frozen=True)
class Selection:
    """The EGL device chosen for this process and how; ``columns()`` are the record's device columns."""

    egl_device: int | None  # None: let glcontext choose (its default, index 0)
    cuda_device: str | None  # the GPU this process was given: first entry of CUDA_VISIBLE_DEVICES
    pci_bus_id: str | None
    how: str  # "cuda" | "env" | "default"
    egl_devices: int = 0
    pci_from: str | None = None  # "uuid" | "drm" (the EGL device's own) | "cuda_visible_devices"

    def columns(self) -> dict:
        """``egl_device`` (the index actually used: glcontext's default is 0 when devices exist),
        ``cuda_device``, ``pci_bus_id``, ``egl_selection`` (how it was chosen) and ``pci_from``."""
        used = self.egl_device if self.egl_device is not None else (0 if self.egl_devices else None)
        return {"egl_device": used, "cuda_device": self.cuda_device, "pci_bus_id": self.pci_bus_id,
                "egl_selection": self.how, "pci_from": self.pci_from}


# ---- querying (ctypes) -------------------------------------------------------------------------------
def _egl_functions(libegl: str | None = None):
    name = libegl or ctypes.util.find_library("EGL") or "libEGL.so.1"
    lib = ctypes.CDLL(name)
    lib.eglGetProcAddress.restype = ctypes.c_void_p
    lib.eglGetProcAddress.argtypes = [ctypes.c_char_p]

    def proc(fname, restype, *argtypes):
        addr = lib.eglGetProcAddress(fname.encode())
        return ctypes.CFUNCTYPE(restype, *argtypes)(addr) if addr else None

    vp, i32 = ctypes.c_void_p, ctypes.c_int32
    return {
        "devices": proc("eglQueryDevicesEXT", ctypes.c_uint, i32, ctypes.POINTER(vp), ctypes.POINTER(i32)),
        "attrib": proc("eglQueryDeviceAttribEXT", ctypes.c_uint, vp, i32, ctypes.POINTER(ctypes.c_ssize_t)),
        "string": proc("eglQueryDeviceStringEXT", ctypes.c_char_p, vp, i32),
        "binary": proc("eglQueryDeviceBinaryEXT", ctypes.c_uint, vp, i32, i32, vp, ctypes.POINTER(i32)),
    }


def _uuid_text(b: bytes) -> str:
    h = b.hex()
    return f"GPU-{h[:8]}-{h[8:12]}-{h[12:16]}-{h[16:20]}-{h[20:32]}"


def query_devices(libegl: str | None = None) -> list[EglDevice]:
    """Every EGL device with its CUDA ordinal, UUID, DRM file and renderer where the driver tells.
    An empty list when EGL or its device extensions are missing (never raises)."""
    try:
        f = _egl_functions(libegl)
    except (OSError, AttributeError):
        return []
    if not f["devices"]:
        return []
    n = ctypes.c_int32(0)
    devs = (ctypes.c_void_p * _MAX_DEVICES)()
    if not f["devices"](_MAX_DEVICES, devs, ctypes.byref(n)):
        return []
    out = []
    for i in range(n.value):
        d = devs[i]
        string = (lambda name: (f["string"](d, name) or b"").decode(errors="replace") or None) \
            if f["string"] else (lambda name: None)
        ext = string(EGL_EXTENSIONS) or ""
        cuda = None
        if "EGL_NV_device_cuda" in ext and f["attrib"]:
            v = ctypes.c_ssize_t(-1)
            if f["attrib"](d, EGL_CUDA_DEVICE_NV, ctypes.byref(v)) and v.value >= 0:
                cuda = int(v.value)
        uuid = None
        if "EGL_EXT_device_persistent_id" in ext and f["binary"]:
            buf, size = ctypes.create_string_buffer(16), ctypes.c_int32(0)
            if f["binary"](d, EGL_DEVICE_UUID_EXT, 16, ctypes.cast(buf, ctypes.c_void_p), ctypes.byref(size)) \
                    and size.value == 16:
                uuid = _uuid_text(buf.raw)
        drm = string(EGL_DRM_DEVICE_FILE_EXT) if "EGL_EXT_device_drm" in ext else None
        renderer = string(EGL_RENDERER_EXT) if "EGL_EXT_device_query_name" in ext else None
        out.append(EglDevice(i, ext, cuda, uuid, drm, renderer))
    return out


def nvidia_gpus() -> list[dict]:
    """``[{"index", "uuid", "pci_bus_id"}]`` of every NVIDIA GPU (nvidia-smi, which ignores
    ``CUDA_VISIBLE_DEVICES``); empty without nvidia-smi."""
    exe = shutil.which("nvidia-smi")
    if not exe:
        return []
    try:
        p = subprocess.run([exe, "--query-gpu=index,uuid,pci.bus_id", "--format=csv,noheader"],
                           capture_output=True, text=True, timeout=_SMI_TIMEOUT_S)
    except (OSError, subprocess.SubprocessError):
        return []
    gpus = []
    for line in p.stdout.splitlines() if p.returncode == 0 else []:
        f = [x.strip() for x in line.split(",")]
        if len(f) == 3:
            gpus.append({"index": f[0], "uuid": f[1], "pci_bus_id": normalize_pci(f[2])})
    return gpus


def normalize_pci(bus_id: str | None) -> str | None:
    """``00000000:18:00.0`` (nvidia-smi) and ``0000:18:00.0`` (sysfs) as ``0000:18:00.0``."""
    if not bus_id:
        return None
    s = bus_id.strip().lower()
    dom, _, rest = s.partition(":")
    if not rest:
        return s
    return f"{int(dom, 16):04x}:{rest}" if all(c in "0123456789abcdef" for c in dom) else s


def drm_pci(drm: str | None, sysfs: str = "/sys/class/drm") -> str | None:
    """PCI address of a ``/dev/dri/cardN`` (or renderD) device through sysfs, if present."""
    if not drm:
        return None
    link = os.path.join(sysfs, os.path.basename(drm), "device")
    try:
        return normalize_pci(os.path.basename(os.path.realpath(link))) if os.path.exists(link) else None
    except OSError:
        return None


# ---- choosing (pure) -----------------------------------------------------------------------------
def visible_gpu(env=None) -> str | None:
    """First entry of ``CUDA_VISIBLE_DEVICES`` (an index or a UUID); None when unset or empty."""
    v = (os.environ if env is None else env).get("CUDA_VISIBLE_DEVICES")
    if v is None:
        return None
    first = v.split(",")[0].strip()
    return first or None


def select(devices: list[EglDevice], *, env=None, gpus: list[dict] | None = None,
           pci_of_drm=drm_pci) -> Selection:
    """The EGL device for this process (see the module docstring for the rules)."""
    env = os.environ if env is None else env
    given = visible_gpu(env)
    gpus = gpus or []
    forced = env.get("GLCONTEXT_DEVICE_INDEX")
    chosen, how = None, "default"
    if forced is not None and forced.strip().lstrip("-").isdigit():
        chosen, how = int(forced), "env"
    else:
        by_cuda = {d.cuda: d.index for d in devices if d.cuda is not None}
        if 0 in by_cuda:
            chosen, how = by_cuda[0], "cuda"
    used = chosen if chosen is not None else 0
    dev = next((d for d in devices if d.index == used), None)
    found = []  # (source, pci bus id): the device's own identity first
    if dev is not None and dev.uuid:
        found += [("uuid", g["pci_bus_id"]) for g in gpus if g["uuid"].lower() == dev.uuid.lower()]
    if dev is not None:
        found.append(("drm", pci_of_drm(dev.drm)))
    if how == "cuda" and given is not None:  # chosen as the CUDA_VISIBLE_DEVICES GPU
        found += [("cuda_visible_devices", g["pci_bus_id"]) for g in gpus if given in (g["index"], g["uuid"])]
    source, pci = next(((s, p) for s, p in found if p), (None, None))
    return Selection(chosen, given, pci, how, len(devices), source)


def select_device(libegl: str | None = None) -> Selection:
    """Query this machine and choose (nvidia-smi is asked only when an NVIDIA EGL device exists)."""
    devices = query_devices(libegl)
    nvidia = any(d.cuda is not None or d.uuid for d in devices)
    return select(devices, gpus=nvidia_gpus() if nvidia else [])
