"""The type stubs describe the extension module: every public name, function parameter and
result attribute of `scatterbake._scatterbake` is in `_scatterbake.pyi` and the reverse."""

import ast
import inspect
import pathlib

import scatterbake
from scatterbake import _scatterbake

PYI = pathlib.Path(scatterbake.__file__).with_name("_scatterbake.pyi")


def stub_tree():
    return ast.parse(PYI.read_text())


def test_stub_files_are_installed():
    assert PYI.is_file()
    assert PYI.with_name("py.typed").is_file()


def test_stub_names_match_the_module():
    tree = stub_tree()
    stubbed = set()
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            stubbed.add(node.name)
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            stubbed.add(node.target.id)
    public = {n for n in dir(_scatterbake) if not n.startswith("_")} | {"__version__"}
    stubbed = {n for n in stubbed if not n.startswith("_") or n == "__version__"}
    assert stubbed == public


def test_stub_signatures_and_attributes_match():
    tree = stub_tree()
    for node in tree.body:
        if isinstance(node, ast.FunctionDef):
            sig = inspect.signature(getattr(_scatterbake, node.name))
            a = node.args
            names = [x.arg for x in a.posonlyargs + a.args + a.kwonlyargs]
            assert names == list(sig.parameters), node.name
            assert ast.get_docstring(node), f"{node.name} has no docstring"
        elif isinstance(node, ast.ClassDef) and node.name != "TableError":
            cls = getattr(_scatterbake, node.name)
            attrs = {
                n.target.id for n in node.body
                if isinstance(n, ast.AnnAssign) and isinstance(n.target, ast.Name)
            } | {n.name for n in node.body if isinstance(n, ast.FunctionDef)}
            real = {n for n in dir(cls) if not n.startswith("_")}
            assert attrs == real, node.name
