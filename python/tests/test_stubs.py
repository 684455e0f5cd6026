"""The type stubs (tumble/_tumble.pyi) name exactly what the extension has, and every public
name has a docstring."""

import ast
import os

import tumble
import tumble._tumble as ext

STUB = os.path.join(os.path.dirname(tumble.__file__), "_tumble.pyi")


def stub_names():
    tree = ast.parse(open(STUB).read())
    out = {}
    for node in tree.body:
        if isinstance(node, ast.ClassDef):
            out[node.name] = {n.name for n in node.body if isinstance(n, ast.FunctionDef) and not n.name.startswith("_")}
        elif isinstance(node, ast.FunctionDef):
            out[node.name] = None
    return out


def test_the_stubs_are_installed_and_match_the_module():
    assert os.path.exists(STUB)
    assert os.path.exists(os.path.join(os.path.dirname(tumble.__file__), "py.typed"))
    stubs = stub_names()
    public = {n for n in dir(ext) if not n.startswith("_")}
    assert set(stubs) == public
    for name, members in stubs.items():
        obj = getattr(ext, name)
        assert obj.__doc__, name
        if members is None or name == "TumbleError":
            continue
        have = {m for m in dir(obj) if not m.startswith("_")}
        assert members == have, (name, members ^ have)
        for m in have:
            assert getattr(obj, m).__doc__, f"{name}.{m}"
