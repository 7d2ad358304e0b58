"""The type stubs (_core.pyi) name every public class, function and method of the module, and
everything has a docstring, so editors complete and document the whole API."""
import ast
import pathlib

import tac3d
import tac3d._core as core

STUB = pathlib.Path(tac3d.__file__).with_name("_core.pyi")
DUNDERS = {"__len__", "__getitem__", "__iter__", "__next__", "__enter__", "__exit__"}


def stub_tree():
    return ast.parse(STUB.read_text())


def test_every_public_name_has_a_stub():
    tree = stub_tree()
    stubbed = {n.name for n in tree.body if isinstance(n, (ast.ClassDef, ast.FunctionDef))}
    public = {n for n in dir(core) if not n.startswith("__")}
    assert public == stubbed
    for cls in (n for n in tree.body if isinstance(n, ast.ClassDef) and n.name != "Error"):
        members = {n.name for n in cls.body if isinstance(n, ast.FunctionDef)}
        members |= {n.target.id for n in cls.body if isinstance(n, ast.AnnAssign)}
        real = {n for n in dir(getattr(core, cls.name)) if not n.startswith("_") or n in DUNDERS}
        assert real - {"__init__"} <= members, (cls.name, real - members)


def test_functions_and_classes_have_docstrings():
    for name in tac3d.__all__:
        obj = getattr(tac3d, name)
        if callable(obj) and not name.startswith("_"):
            assert obj.__doc__ and len(obj.__doc__.strip()) > 20, name
