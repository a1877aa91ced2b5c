"""EGL device selection (ldbench/core/egl.py): the CUDA_VISIBLE_DEVICES GPU found through EGL_NV_device_cuda.

CI has no NVIDIA GPU: the selection rules are checked on fake device lists shaped like what the NVIDIA
driver reports (EGL order differing from CUDA's and from nvidia-smi's), and the ctypes query and the
context creation on this machine's (llvmpipe) device."""
import os

import pytest

from ldbench.core import egl
from ldbench.core.egl import EglDevice, Selection, normalize_pci, select

NV_EXT = "EGL_NV_device_cuda EGL_EXT_device_drm EGL_EXT_device_persistent_id"
SMI = [  # nvidia-smi order (PCI); CUDA's order here differs, as does EGL's
    {"index": "0", "uuid": "GPU-00000000-0000-0000-0000-0000000000a0", "pci_bus_id": "0000:18:00.0"},
    {"index": "1", "uuid": "GPU-00000000-0000-0000-0000-0000000000a1", "pci_bus_id": "0000:2a:00.0"},
    {"index": "2", "uuid": "GPU-00000000-0000-0000-0000-0000000000a2", "pci_bus_id": "0000:3a:00.0"},
]


def _nv(index, cuda, gpu, drm=None, uuid=True):
    return EglDevice(index, NV_EXT, cuda, SMI[gpu]["uuid"] if uuid else None, drm)


def test_cuda_visible_gpu_maps_to_its_egl_device_not_the_same_index():
    # The task was given GPU 2: in its CUDA numbering that is ordinal 0, and EGL lists it first.
    devices = [_nv(0, 0, 2), _nv(1, None, 0), _nv(2, None, 1), EglDevice(3, "EGL_MESA_device_software")]
    sel = select(devices, env={"CUDA_VISIBLE_DEVICES": "2"}, gpus=SMI)
    assert (sel.egl_device, sel.how, sel.cuda_device) == (0, "cuda", "2")
    assert sel.pci_bus_id == "0000:3a:00.0"  # from the EGL device's own UUID
    assert sel.columns() == {"egl_device": 0, "cuda_device": "2", "pci_bus_id": "0000:3a:00.0",
                             "egl_selection": "cuda", "pci_from": "uuid"}


def test_all_gpus_visible_picks_cuda_ordinal_zero():
    devices = [_nv(0, 1, 1), _nv(1, 0, 0), _nv(2, 2, 2)]
    sel = select(devices, env={}, gpus=SMI)
    assert (sel.egl_device, sel.how, sel.cuda_device, sel.pci_bus_id) == (1, "cuda", None, "0000:18:00.0")


def test_pci_from_drm_then_from_cuda_visible_devices():
    devices = [_nv(0, None, 0, uuid=False), _nv(1, 0, 1, drm="/dev/dri/card3", uuid=False)]
    seen = []
    sel = select(devices, env={"CUDA_VISIBLE_DEVICES": "1"}, gpus=SMI,
                 pci_of_drm=lambda d: seen.append(d) or ("0000:2a:00.0" if d else None))
    assert (sel.egl_device, sel.pci_bus_id, sel.pci_from, seen) == (1, "0000:2a:00.0", "drm", ["/dev/dri/card3"])
    sel = select(devices, env={"CUDA_VISIBLE_DEVICES": "GPU-00000000-0000-0000-0000-0000000000a1"},
                 gpus=SMI, pci_of_drm=lambda d: None)  # nothing from EGL: the given GPU's (by UUID)
    assert (sel.pci_bus_id, sel.pci_from) == ("0000:2a:00.0", "cuda_visible_devices")


def test_no_nvidia_device_keeps_the_default():
    sw = [EglDevice(0, "EGL_MESA_device_software EGL_EXT_device_drm_render_node")]
    for env in ({}, {"CUDA_VISIBLE_DEVICES": ""}, {"CUDA_VISIBLE_DEVICES": "0"}):
        sel = select(sw, env=env, gpus=[])
        assert (sel.egl_device, sel.how, sel.pci_bus_id) == (None, "default", None)
        assert sel.columns()["egl_device"] == 0  # glcontext's default
    # NVIDIA devices that CUDA does not see (CUDA_VISIBLE_DEVICES=""): none answers, default again
    sel = select([_nv(0, None, 0), _nv(1, None, 1)], env={"CUDA_VISIBLE_DEVICES": ""}, gpus=SMI)
    assert (sel.egl_device, sel.how, sel.cuda_device) == (None, "default", None)
    assert select([], env={}).columns()["egl_device"] is None  # no EGL devices at all


def test_glcontext_device_index_wins():
    devices = [_nv(0, 1, 1), _nv(1, 0, 0)]
    sel = select(devices, env={"GLCONTEXT_DEVICE_INDEX": "0", "CUDA_VISIBLE_DEVICES": "0"}, gpus=SMI)
    assert (sel.egl_device, sel.how, sel.pci_bus_id) == (0, "env", "0000:2a:00.0")  # device 0's own UUID


def test_pci_helpers(tmp_path):
    assert normalize_pci("00000000:18:00.0") == "0000:18:00.0"
    assert normalize_pci("0000:3A:00.0") == "0000:3a:00.0"
    assert normalize_pci(None) is None
    assert egl._uuid_text(bytes(range(16))) == "GPU-00010203-0405-0607-0809-0a0b0c0d0e0f"
    pci = tmp_path / "devices" / "0000:3b:00.0"
    pci.mkdir(parents=True)
    (tmp_path / "drm" / "card1").mkdir(parents=True)
    os.symlink(pci, tmp_path / "drm" / "card1" / "device")
    assert egl.drm_pci("/dev/dri/card1", sysfs=str(tmp_path / "drm")) == "0000:3b:00.0"
    assert egl.drm_pci("/dev/dri/card9", sysfs=str(tmp_path / "drm")) is None


def test_this_machine_query_and_context(monkeypatch):
    """The ctypes query runs here (llvmpipe: a software device without a CUDA ordinal), and the GL
    context opens on the selected index."""
    devices = egl.query_devices()
    assert devices and all(d.cuda is None for d in devices if "EGL_NV_device_cuda" not in d.extensions)
    assert [d.index for d in devices] == list(range(len(devices)))
    import moderngl

    from ldbench.core import gpu as gpu_mod

    calls = []
    real = moderngl.create_standalone_context
    monkeypatch.setattr(moderngl, "create_standalone_context", lambda **kw: calls.append(kw) or real(**kw))
    monkeypatch.setattr(egl, "select_device",
                        lambda: Selection(len(devices) - 1, "7", "0000:99:00.0", "cuda", 1, "uuid"))
    g = gpu_mod.Gpu()
    try:
        assert calls[-1]["device_index"] == len(devices) - 1
        assert g.device_columns == {"egl_device": len(devices) - 1, "cuda_device": "7",
                                    "pci_bus_id": "0000:99:00.0", "egl_selection": "cuda", "pci_from": "uuid"}
    finally:
        g.release()
    monkeypatch.setattr(egl, "select_device", lambda: (_ for _ in ()).throw(OSError("broken libEGL")))
    g = gpu_mod.Gpu()  # a failing query: today's behaviour (no device_index)
    try:
        assert "device_index" not in calls[-1] and g.selection.how == "default"
    finally:
        g.release()


@pytest.mark.skipif(not os.path.exists("/dev/nvidiactl"), reason="needs an NVIDIA GPU")
def test_nvidia_machine_maps_every_visible_gpu():  # pragma: no cover - GPU machines only
    devices = egl.query_devices()
    assert any(d.cuda == 0 for d in devices), devices
