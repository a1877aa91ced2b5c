"""The binding table (ldbench/core/bindings.py): its invariants, the GLSL header, and the loader's check that
refuses a program whose blocks disagree with it. Every program the harness compiles goes through that
check, so the method tests (test_builds, test_ldm, test_ldi, ...) check every shader variant they build."""
import numpy as np
import pytest

from ldbench.core import bindings
from ldbench.core.bindings import TABLE, B
from ldbench.core.errors import LdbenchError
from ldbench.core.gpu import METHODS_DIR, check_bindings


def test_table_is_consistent():
    assert bindings.table_errors() == []
    assert {b.kind for b in TABLE.values()} <= set(bindings.KINDS)
    # ldbench/methods/structures/linked.py binds node page p at B_NODES0 + p
    assert [B.NODES0 + p for p in range(4)] == [B.NODES0, B.NODES1, B.NODES2, B.NODES3]


def test_table_errors_catch_a_clash(monkeypatch):
    monkeypatch.setitem(bindings._TABLE, "EXTRA", bindings.Binding("ssbo", B.RAYS, "rays", "x", ("Extra",)))
    monkeypatch.setitem(bindings._TABLE, "EXTRA2", bindings.Binding("blob", 1, "x", "x", ("Blob",)))
    monkeypatch.setitem(bindings._TABLE, "EXTRA3", bindings.Binding("ssbo", 30, "x", "x", ("RayBatch",)))
    errs = bindings.table_errors()
    assert any("EXTRA and RAYS" in e or "RAYS and EXTRA" in e for e in errs)
    assert any("kind 'blob'" in e for e in errs) and any("'RayBatch'" in e for e in errs)


def test_numbers_fit_the_gl_limits(gpu):
    ssbo = [b.number for b in TABLE.values() if b.kind == "ssbo"]
    assert max(ssbo) < int(gpu.ctx.info["GL_MAX_SHADER_STORAGE_BUFFER_BINDINGS"])
    assert max(ssbo) <= 21  # the highest binding the kernels used before the table (NVIDIA exposes more)


def test_names_are_read_only():
    with pytest.raises(AttributeError, match="no binding 'RAYZ'"):
        B.RAYZ
    with pytest.raises(AttributeError):
        B.RAYS = 3


def test_header_reaches_the_shader(tmp_path, gpu):
    """B_NAME in GLSL is the table's number: a kernel writes through B_HITS into the buffer Python bound at
    B.HITS, and the compiled block reports that binding."""
    (tmp_path / "k.glsl").write_text(
        "layout(local_size_x = 1) in;\n"
        "layout(std430, binding = B_HITS) writeonly buffer RayHits { float ray_t[]; };\n"
        "void main() { ray_t[0] = float(B_RAYS); }\n")
    cs = gpu.compute(tmp_path / "k.glsl")
    assert cs["RayHits"].binding == B.HITS == 21
    buf = gpu.ctx.buffer(reserve=4)
    buf.bind_to_storage_buffer(B.HITS)
    cs.run(1)
    gpu.ctx.finish()
    assert np.frombuffer(buf.read(), "f4")[0] == B.RAYS
    buf.release()


@pytest.mark.parametrize("decl, message", [
    # a known block at another number than the table's (a literal, or the wrong name)
    ("layout(std430, binding = 21) buffer RayBatch { float r[]; };",
     "RayBatch at binding 21, the table says B_RAYS = 20"),
    ("layout(std430, binding = B_LDM_LUT) buffer CdiLut { float r[]; };",
     "CdiLut at binding 13, the table says B_CDI_LUT = 12"),
    # two blocks on one binding: the second would read the first's buffer
    ("layout(std430, binding = 5) buffer Foo { float r[]; };\n"
     "layout(std430, binding = 5) buffer Bar { float q[]; };", "share binding 5"),
    # an image at another unit
    ("layout(r32f, binding = 2) writeonly uniform image2D out_image;", "out_image at unit 2"),
])
def test_a_disagreeing_program_is_refused(tmp_path, gpu, decl, message):
    uses = {"RayBatch": "r[0] = 1.0;", "CdiLut": "r[0] = 1.0;", "Foo": "r[0] = q[0];",
            "out_image": "imageStore(out_image, ivec2(0), vec4(1.0));"}
    body = next(v for k, v in uses.items() if k in decl)
    (tmp_path / "bad.glsl").write_text(f"layout(local_size_x = 1) in;\n{decl}\nvoid main() {{ {body} }}\n")
    with pytest.raises(LdbenchError, match=message):
        gpu.compute(tmp_path / "bad.glsl")


def test_project_shaders_must_name_their_blocks(tmp_path, gpu):
    """A block the table does not know passes in a test's scratch kernel, not in a shader under methods/."""
    (tmp_path / "k.glsl").write_text("layout(local_size_x = 1) in;\n"
                                     "layout(std430, binding = 3) buffer Mystery { float m[]; };\n"
                                     "void main() { m[0] = 1.0; }\n")
    cs = gpu.compute(tmp_path / "k.glsl")
    check_bindings(cs, tmp_path / "k.glsl")
    assert bindings.program_mismatches(cs, strict=True) == [
        "storage block Mystery is not in the binding table (ldbench/core/bindings.py)"]
    with pytest.raises(LdbenchError, match="Mystery is not in the binding table"):
        check_bindings(gpu.ctx.compute_shader(
            "#version 430\nlayout(local_size_x = 1) in;\nlayout(std430, binding = 3) buffer Mystery { float m[]; };\n"
            "void main() { m[0] = 1.0; }\n"), METHODS_DIR / "glsl" / "k.glsl")


def test_the_project_shaders_agree(gpu):
    """The shaders that compile alone, with their default defines, as their methods compile them."""
    from ldbench.core.gpu import GLSL_DIR
    progs = [gpu.program(GLSL_DIR / "gbuffer/gbuffer.glsl"), gpu.program(GLSL_DIR / "layered/build.glsl"),
             gpu.compute(GLSL_DIR / "layered/linked_list_sort.glsl"), gpu.compute(GLSL_DIR / "layered/pairs_scatter.glsl"),
             gpu.compute(GLSL_DIR / "common/scan.glsl"), gpu.compute(GLSL_DIR / "layered/peel_commit.glsl"),
             gpu.compute(METHODS_DIR / "ldm" / "photon_trace.glsl"),
             gpu.compute(METHODS_DIR / "ldi" / "trace_rays.glsl")]
    for p in progs:
        assert bindings.program_mismatches(p) == []
    blocks = {p[k].name: p[k].binding for p in progs for k in p if type(p[k]).__name__ == "StorageBlock"}
    assert blocks["RayBatch"] == B.RAYS and blocks["Photons"] == B.PHOTONS and blocks["LSPairs"] == B.PAIRS
