"""GPU context, shader loading, memory accounting, timing, read-back orientation, adapter contract."""
import numpy as np
import pytest

from ldbench.core.errors import LdbenchError
from ldbench.core.gpu import classify_device, expand_includes, read_texture
from ldbench.core.paramdoc import markdown
from ldbench.core.params import ParamsBase, param
from ldbench.methods.base import registry, get_method
from dataclasses import dataclass


def test_classify_device():
    assert classify_device("llvmpipe (LLVM 15.0.6, 256 bits)", "Mesa") == "cpu-software"
    assert classify_device("NVIDIA H100 80GB HBM3/PCIe/SSE2", "NVIDIA Corporation") == "nvidia"
    assert classify_device("AMD Radeon RX 7900", "AMD") == "gpu"


def test_include_and_defines(tmp_path, gpu):
    (tmp_path / "inc.glsl").write_text("float twice(float x) { return 2.0 * x; }\n")
    (tmp_path / "k.glsl").write_text(
        '#include "inc.glsl"\n#include "common/common.glsl"\nlayout(local_size_x = 1) in;\n'
        "layout(std430, binding = 0) buffer B { float v[]; };\n"
        "void main() { v[0] = twice(SCALE) + PI * 0.0; }\n")
    assert "twice" in expand_includes(tmp_path / "k.glsl")
    cs = gpu.compute(tmp_path / "k.glsl", {"SCALE": "3.5"})
    buf = gpu.ctx.buffer(reserve=4)
    buf.bind_to_storage_buffer(0)
    cs.run(1)
    assert np.frombuffer(buf.read(), "f4")[0] == pytest.approx(7.0)
    (tmp_path / "bad.glsl").write_text('#include "missing.glsl"\n')
    with pytest.raises(LdbenchError, match="missing.glsl"):
        expand_includes(tmp_path / "bad.glsl")
    (tmp_path / "err.glsl").write_text("layout(local_size_x = 1) in; void main() { undefined_fn(); }\n")
    with pytest.raises(LdbenchError, match="err.glsl failed to compile"):
        gpu.compute(tmp_path / "err.glsl")


def test_shared_includes_are_namespaced(tmp_path, caplog):
    """Shared shader files live in folders the include names (``common/common.glsl``). A plugin's include by
    a bare shared name (as written before the folders) still resolves, with a deprecation message naming the
    new spelling; the project's own shaders get no such fallback, and a missing include names file:line."""
    from ldbench.core import gpu as gpumod
    (tmp_path / "old.glsl").write_text('// a plugin\n#include "common.glsl"\n')
    with caplog.at_level("WARNING", logger="ldbench.core.gpu"):
        assert "PI" in expand_includes(tmp_path / "old.glsl")
    assert '#include "common/common.glsl"' in caplog.text
    (tmp_path / "gone.glsl").write_text('// a plugin\n\n#include "no_such_file.glsl"\n')
    with pytest.raises(LdbenchError, match=rf"{tmp_path}/gone.glsl:3: #include \"no_such_file.glsl\" not found"):
        expand_includes(tmp_path / "gone.glsl")
    inside = gpumod.METHODS_DIR / "ldm" / "_probe_flat_include.glsl"
    try:
        inside.write_text('#include "common.glsl"\n')
        with pytest.raises(LdbenchError, match=r"ldm/_probe_flat_include.glsl:1: #include \"common.glsl\" not found"):
            expand_includes(inside)
    finally:
        inside.unlink()
    assert not list(gpumod.GLSL_DIR.glob("*.glsl")), "shared shader files belong in a folder of glsl/"


def test_compile_errors_name_the_file_and_line(tmp_path, gpu):
    """A compile error reads ``file:line: message`` with the line of the file it is in, whether that is an
    include (here two deep) or the including file after its includes; a file outside methods/ (a plugin's) is
    named by its full path, the project's own relative to methods/. Mesa's and NVIDIA's formats both parse."""
    (tmp_path / "deep.glsl").write_text("// a comment\nfloat deep(float x) { return x; }\n")
    (tmp_path / "inc.glsl").write_text('#include "deep.glsl"\nfloat twice(float x) {\n'
                                       "    return 2.0 * missing_in_inc;\n}\n")
    (tmp_path / "k.glsl").write_text('#include "inc.glsl"\n#include "common/common.glsl"\nlayout(local_size_x = 1) in;\n'
                                     "void main() { float y = twice(1.0); }\n")
    with pytest.raises(LdbenchError, match=rf"k.glsl failed to compile: {tmp_path}/inc.glsl:3: .*missing_in_inc"):
        gpu.compute(tmp_path / "k.glsl")
    (tmp_path / "inc.glsl").write_text('#include "deep.glsl"\nfloat twice(float x) { return 2.0 * x; }\n')
    (tmp_path / "k.glsl").write_text('#include "inc.glsl"\n#include "common/common.glsl"\nlayout(local_size_x = 1) in;\n'
                                     "void main() {\n    float y = twice(missing_in_main);\n}\n")
    with pytest.raises(LdbenchError, match=rf"{tmp_path}/k.glsl:5: .*missing_in_main"):
        gpu.compute(tmp_path / "k.glsl")
    (tmp_path / "k.glsl").write_text('// blank lines before an include\n\n\n#include "deep.glsl"\n'
                                     "layout(local_size_x = 1) in;\nvoid main() { float y = missing_after_blank; }\n")
    with pytest.raises(LdbenchError, match=rf"{tmp_path}/k.glsl:6: .*missing_after_blank"):
        gpu.compute(tmp_path / "k.glsl")
    (tmp_path / "v.glsl").write_text('#if defined(VERTEX_SHADER)\nvoid main() { gl_Position = vec4(0.0); }\n'
                                     '#elif defined(FRAGMENT_SHADER)\n#include "deep.glsl"\nout vec4 c;\n'
                                     "void main() { c = vec4(nope); }\n#endif\n")
    with pytest.raises(LdbenchError, match=rf"{tmp_path}/v.glsl:6: .*nope"):
        gpu.program(tmp_path / "v.glsl")


@pytest.mark.parametrize("text, where", [
    ("0:46(12): error: `x' undeclared", "a.glsl:46: error: `x' undeclared"),                  # Mesa
    ("0(100007) : error C1008: undefined variable \"x\"", "b.glsl:7: error C1008: undefined variable \"x\""),  # NVIDIA
])
def test_compile_error_formats(tmp_path, text, where):
    from ldbench.core.gpu import compile_error

    files = [tmp_path / "a.glsl", tmp_path / "b.glsl"]
    assert compile_error(Exception(f"GLSL Compiler failed\n\ncompute_shader\n=====\n{text}\n"), files) == \
        f"{tmp_path}/{where}"


def test_resources_count_bytes(gpu):
    res = gpu.resources("x.")
    res.buffer("a", reserve=1000)
    res.texture("t", (16, 8), 4, "f4")
    assert res.by_buffer() == {"x.a": 1000, "x.t": 16 * 8 * 16}
    res.release()
    assert res.total() == 0


def test_readback_row0_is_top(gpu):
    """A triangle covering only the upper half of clip space must land in the first rows."""
    prog = gpu.ctx.program(
        vertex_shader="#version 430\nin vec2 p; void main() { gl_Position = vec4(p, 0, 1); }",
        fragment_shader="#version 430\nout vec4 c; void main() { c = vec4(1); }")
    vbo = gpu.ctx.buffer(np.array([-1, 0.1, 3, 0.1, -1, 3], "f4"))
    vao = gpu.ctx.vertex_array(prog, [(vbo, "2f", "p")])
    tex = gpu.ctx.texture((8, 8), 4, dtype="f4")
    fbo = gpu.ctx.framebuffer([tex])
    fbo.use()
    fbo.clear()
    vao.render()
    img = read_texture(tex, 1)[..., 0]
    assert img[:4].min() == 1 and img[4:].max() == 0


def test_stage_timing(gpu):
    gpu.begin_frame()
    with gpu.stage("a"):
        gpu.ctx.buffer(reserve=1024).release()
    with gpu.stage("a"):
        pass
    with gpu.stage("b"):
        pass
    stages, wall = gpu.end_frame()
    assert set(stages) == {"a", "b"} and all(v >= 0 for v in stages.values()) and wall > 0


@dataclass(frozen=True)
class _P(ParamsBase):
    n: int = param(4, "count", lo=1, hi=8)
    mode: str = param("a", "mode", choices=("a", "b"))
    on: bool = param(True, "flag")


def test_params_validation():
    assert _P.from_dict({"n": "5", "on": "false"}) == _P(n=5, on=False)
    for bad, msg in (({"n": 9}, "above its maximum"), ({"n": 0}, "below its minimum"),
                     ({"mode": "c"}, "not one of"), ({"zzz": 1}, "unknown parameter 'zzz'"),
                     ({"n": 1.5}, "not a valid int")):
        with pytest.raises(LdbenchError, match=msg):
            _P.from_dict(bad, method="m")
    assert "count" in markdown(_P)


def test_registry_discovers_adapters():
    reg = registry()
    assert "direct-raster" in reg
    assert get_method("direct-raster").effects == frozenset({"direct"})
    with pytest.raises(LdbenchError, match="unknown method"):
        get_method("nope")


def test_a_second_context_released_leaves_the_first_usable(gpu):
    """A run started from inside a process that holds a context (a test session, a notebook) creates and
    releases its own; the first context must still compute afterwards (EGL leaves none current)."""
    from ldbench.core.gpu import GLSL_DIR, Gpu

    buf = gpu.ctx.buffer(reserve=64)
    cs = gpu.compute(GLSL_DIR / "common/fill_uint.glsl")
    other = Gpu()
    other.compute(GLSL_DIR / "common/fill_uint.glsl")
    other.release()
    cs["n"].value, cs["value"].value = 16, 7
    buf.bind_to_storage_buffer(0)
    cs.run(1)
    gpu.ctx.finish()
    assert (np.frombuffer(buf.read(), np.uint32) == 7).all()
    buf.release()


def test_read_goes_through_staging(gpu):
    """gpu.read returns the bytes asked for (offset, size, growing staging) and never reads the buffer
    itself: NVIDIA moves a buffer the CPU reads to host memory (ldbench/core/gpu.py Gpu.read)."""
    data = np.arange(5000, dtype=np.uint32)
    buf = gpu.ctx.buffer(data.tobytes())
    direct = []
    orig = buf.read
    buf.read = lambda *a, **k: direct.append(1) or orig(*a, **k)
    try:
        assert np.array_equal(np.frombuffer(gpu.read(buf, 8, offset=4 * 17), np.uint32), [17, 18])
        assert np.array_equal(np.frombuffer(gpu.read(buf), np.uint32), data)  # staging grows past 4 KiB
        assert gpu.read(buf, 0) == b"" and not direct
        import ldbench.core.gpu as G

        keep, G.STAGING_KEEP = G.STAGING_KEEP, 1024  # a read above the kept size: its own staging buffer
        try:
            kept = gpu._staging
            assert np.array_equal(np.frombuffer(gpu.read(buf, 4000, offset=400), np.uint32), data[100:1100])
            assert gpu._staging is kept and not direct
        finally:
            G.STAGING_KEEP = keep
    finally:
        buf.read = orig
        buf.release()


def test_methods_never_read_gpu_buffers_directly():
    """Every buffer read-back in methods/ goes through gpu.read (textures excepted)."""
    import re
    from pathlib import Path

    root = Path(__file__).resolve().parents[1] / "ldbench" / "methods"
    bad = []
    for f in root.rglob("*.py"):
        for i, line in enumerate(f.read_text().splitlines(), 1):
            for m in re.finditer(r"([\w\]\)\"]+)\.read\(", line):
                if m.group(1) not in ("gpu", "self", "tex", "texture") and "open(" not in line:
                    bad.append(f"{f.relative_to(root)}:{i}: {line.strip()}")
    assert not bad, "\n".join(bad)
