"""Static tools read the layout as Python does: ldbench is a plain package folder, so an editor's
go-to-definition (jedi) finds every layer's modules from the checkout, with no import hook to run.
(mypy checks the same from ``make typecheck``.)"""
import pytest

from layout import PACKAGE, ROOT, packages

jedi = pytest.importorskip("jedi")


@pytest.mark.parametrize("layer", packages())
def test_jedi_finds_every_layer(layer):
    """``import ldbench.<layer>`` goes to ``ldbench/<layer>/__init__.py`` in this checkout."""
    code = f"import ldbench.{layer}\nldbench.{layer}\n"
    names = jedi.Script(code, path=ROOT / "probe.py", project=jedi.Project(ROOT)).goto(2, len("ldbench.") + 1)
    assert names and names[0].module_path == PACKAGE / layer / "__init__.py", names


def test_jedi_goes_to_a_definition():
    """A name imported from a module deep in a layer resolves to its definition."""
    code = "from ldbench.core.errors import LdbenchError\nLdbenchError\n"
    (d,) = jedi.Script(code, path=ROOT / "probe.py", project=jedi.Project(ROOT)).goto(2, 3, follow_imports=True)
    assert d.module_path == PACKAGE / "core" / "errors.py" and d.type == "class", d
