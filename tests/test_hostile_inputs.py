"""Hostile inputs, refused in one line (exit 2, no traceback) before any work: OBJ faces that name vertex 0 or
one out of range, question.json sizes that are not whole numbers or beyond the budget, the inputs a size
needs (rays per pixel, an RSM) beyond this machine's memory, and ``new-method`` names that are taken."""
import json
from pathlib import Path

import numpy as np
import pytest

from ldbench.core.errors import LdbenchError
from ldbench.harness.cli import main
from test_cli import assert_one_line_error


# ---- OBJ indices ------------------------------------------------------------------------------------------
OBJ_HEAD = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\n# f 0 0 0 in a comment is no face\nf 1 2 3\n"


@pytest.mark.parametrize("face,line,needle", [
    ("f 0 1 2", 7, "face index 0"),            # trimesh read 0 as -1: the last vertex, silently
    ("f 1/0 2/1 3/1", 7, "face index 0"),      # a texture index 0 moved the vertices
    ("f 1 2 3 0", 7, "face index 0"),
    ("f 1 2 9", 7, "face index 9 out of range"),
    ("f -1 -2 -4", 7, "face index -4 out of range"),
])
def test_obj_face_index_zero_or_out_of_range_is_one_line_naming_its_line(tmp_path, capsys, face, line, needle):
    from ldbench.core.meshio import read_mesh

    p = tmp_path / "m.obj"
    p.write_text(OBJ_HEAD + face + "\n")
    with pytest.raises(LdbenchError, match=f"m.obj:{line}: {needle}"):
        read_mesh(p)
    rc = main(["export", "--scene", str(p), "--effect", "ao", "--size", "8x8", "--out", str(tmp_path / "q")])
    assert_one_line_error(rc, capsys.readouterr().err, f"m.obj:{line}", needle)
    assert sorted(x.name for x in tmp_path.iterdir()) == ["m.obj"]


def test_obj_relative_indices_read_as_the_format_says_or_refused(tmp_path):
    """Relative indices count back from the latest vertex: read right where no vertex follows them, refused
    where one does (trimesh would count from the file's last vertex: other triangles, silently)."""
    from ldbench.core.meshio import read_mesh

    more = "".join(f"v {i} 1 0\n" for i in range(8))
    p = tmp_path / "ok.obj"
    p.write_text(OBJ_HEAD + more + "f 10 11 3\nf -3 -2 -1\n")
    v, f = read_mesh(p)
    assert len(f) == 3 and len(v) == 6 and sorted(map(tuple, v[f[2]])) == [(5, 1, 0), (6, 1, 0), (7, 1, 0)]
    p.write_text(OBJ_HEAD + "f -3 -2 -1\n" + more + "f 10 11 3\n")
    with pytest.raises(LdbenchError, match="ok.obj:7: a relative .negative. face index with vertices after it"):
        read_mesh(p)


# ---- question.json and budgets ----------------------------------------------------------------------------
def _question(folder: Path, **changes) -> Path:
    q = {"scene": "cornell", "effect": {"effect": "rays", "ray_kind": "diffuse", "rays_per_pixel": 1},
         "width": 8, "height": 8, "spp": 1, "seed": 0, "ldbench_version": "x"}
    folder.mkdir(parents=True)
    (folder / "question.json").write_text(json.dumps({**q, **changes}))
    np.save(folder / "answer.npy", np.zeros(64, np.float32))
    return folder


@pytest.mark.parametrize("changes,needle", [
    ({"width": 256.5}, "width must be an integer, got 256.5"),
    ({"height": "256"}, "height must be an integer, got '256'"),
    ({"width": True}, "width must be an integer, got True"),
    ({"spp": 2.0}, "spp must be an integer"),
    ({"seed": -1}, "seed must be >= 0"),
    ({"seed": 2 ** 40}, "seed must be <= 4294967295"),
    ({"width": 2}, "out of range"),
    ({"width": 16384, "height": 16384, "spp": 2 ** 20,
      "effect": {"effect": "ao", "d_max": "inf", "falloff": "step"}}, "limit of 2^40"),
    ({"effect": "rays"}, "not an ldbench question"),
])
def test_question_json_sizes_are_whole_numbers_within_the_budget(tmp_path, capsys, changes, needle):
    """score --from reads each question.json as strictly as the command line: no float, string or boolean
    size, spp or seed, and the same budget check before anything is rendered or written."""
    _question(tmp_path / "qs" / "a", **changes)
    rc = main(["score", str(tmp_path / "run"), "--from", str(tmp_path / "qs"), "--no-report"])
    assert_one_line_error(rc, capsys.readouterr().err, "question.json", needle)
    assert not (tmp_path / "run").exists()


def test_rays_per_pixel_and_rsm_size_count_in_the_memory_budget(tmp_path, monkeypatch, capsys):
    """The inputs a size needs are checked with the image's own before any work, from every source (export's
    flags, run's flags and suites, question.json): a rays batch of rays_per_pixel rays for each pixel, the VPLs
    of a vpl_range RSM. A size whose image fits but whose rays do not is refused in one line."""
    from ldbench.core import gpu
    from ldbench.core.effects import Effect
    from ldbench.core.effects.rays import RAY_BYTES
    from ldbench.harness.suite import check_budget

    monkeypatch.setattr(gpu, "host_available_bytes", lambda: 1 << 30)  # this machine, made small: 1 GiB free
    check_budget(64, 64, 1, Effect("rays", rays_per_pixel=4))  # 16 MiB of rays
    with pytest.raises(LdbenchError, match=r"rays_per_pixel = 1024.*GiB of memory"):
        check_budget(64, 64, 1, Effect("rays", rays_per_pixel=1024))  # 1 GiB of rays
    assert 64 * 64 * 1024 * RAY_BYTES >= 1 << 30 > 64 * 64 * gpu.HOST_BYTES_PER_PIXEL
    check_budget(8, 8, 1, Effect("vpl_range", rsm=256))
    with pytest.raises(LdbenchError, match="rsm = 2048"):
        check_budget(8, 8, 1, Effect("vpl_range", rsm=2048))
    big = ("--effect", "rays", "--rays-per-pixel", "1024", "--size", "64x64")
    for argv in (["export", "--scene", "cornell", *big, "--out", str(tmp_path / "q")],
                 ["run", "--scene", "cornell", "--method", "ldm", *big, "--spp", "1", "--no-report", "--out",
                  str(tmp_path / "r")]):
        assert_one_line_error(main(argv), capsys.readouterr().err, "rays_per_pixel = 1024", "memory")
    suite = tmp_path / "s.toml"
    suite.write_text('[suite]\nsize = "64x64"\n[[run]]\nscene = "cornell"\neffect = "rays"\nmethods = ["ldm"]\n'
                     'effect_params = {rays_per_pixel = 1024}\n')
    assert_one_line_error(main(["run", str(suite), "--out", str(tmp_path / "r")]), capsys.readouterr().err,
                          "rays_per_pixel = 1024")
    _question(tmp_path / "qs" / "a", width=64, height=64,
              effect={"effect": "rays", "ray_kind": "diffuse", "rays_per_pixel": 1024})
    rc = main(["score", str(tmp_path / "r"), "--from", str(tmp_path / "qs"), "--no-report"])
    assert_one_line_error(rc, capsys.readouterr().err, "question.json", "rays_per_pixel = 1024")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["qs", "s.toml"]


# ---- new-method names ---------------------------------------------------------------------------------------
def test_new_method_refuses_a_taken_name_and_writes_nothing(tmp_path, monkeypatch, capsys):
    """A name an existing method has (by name or alias), a module name that shadows an importable one (json)
    or an in-tree module (gbuffer): one line, exit 2, nothing written; a write that fails midway removes what
    it wrote."""
    import ldbench.methods
    from ldbench.harness import newmethod

    for name, needle in (("hbao", "taken by the existing method 'hbao'"), ("ldm-ao", "existing method 'ldm'"),
                         ("json", "module 'json' is already importable")):
        rc = main(["new-method", name, "--out", str(tmp_path / name)])
        assert_one_line_error(rc, capsys.readouterr().err, needle)
    tree = tmp_path / "tree"  # a stand-in for ldbench/methods/: nothing is ever written into the checkout here
    tree.mkdir()
    (tree / "gbuffer.py").write_text("# the shared G-buffer\n")
    monkeypatch.setattr(ldbench.methods, "__path__", [str(tree)])
    assert_one_line_error(main(["new-method", "gbuffer", "--in-tree"]), capsys.readouterr().err,
                          "gbuffer.py exists")
    assert sorted(p.name for p in tree.iterdir()) == ["gbuffer.py"]

    class Broken(str):
        def format(self, **kw):
            raise OSError(28, "No space left on device")

    monkeypatch.setattr(newmethod, "GLSL", Broken(""))
    with pytest.raises(OSError):
        newmethod.write_template("fresh-name", out=tmp_path / "deep" / "fresh")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["tree"]
