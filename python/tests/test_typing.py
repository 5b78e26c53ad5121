"""Typing: the hand-written ``_native.pyi`` declares every class, method and function the
native module has (no ``__getattr__`` fallback, ``Robot`` typed member by member), and every
public function and method of the package is annotated (``py.typed`` ships)."""

import ast
import importlib
import inspect
import pathlib

import pytest

import selfmanip
from selfmanip import _native

PKG = pathlib.Path(selfmanip.__file__).parent


def stub():
    return ast.parse((PKG / "_native.pyi").read_text())


def test_stub_declares_everything_the_native_module_has():
    tree = stub()
    top = {n.name for n in tree.body if isinstance(n, (ast.FunctionDef, ast.ClassDef))}
    # module constants are declared with their type (`NAME: int`)
    top |= {n.target.id for n in tree.body if isinstance(n, ast.AnnAssign) and isinstance(n.target, ast.Name)}
    assert "__getattr__" not in top
    public = {n for n in dir(_native) if not n.startswith("_")}
    assert public - top == set(), "undeclared in _native.pyi"
    assert {n for n in top if not n.startswith("_")} - public == set(), "declared but missing"
    robot = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == "Robot")
    members = {n.name for n in robot.body if isinstance(n, ast.FunctionDef)}
    assert {n for n in dir(_native.Robot) if not n.startswith("_")} - members == set()
    # every declared function is annotated
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef):
            args = [a for a in node.args.args + node.args.kwonlyargs if a.arg not in ("self", "cls")]
            assert node.returns is not None and all(a.annotation is not None for a in args), node.name


def test_py_typed_ships():
    assert (PKG / "py.typed").exists()


MODULES = ["robot", "rhex", "leap", "actuator", "analysis", "motor", "plots", "figures", "distributed", "errors",
           "cli_leap"]


def public_callables(mod):
    for name, obj in vars(mod).items():
        if name.startswith("_") or getattr(obj, "__module__", None) != mod.__name__:
            continue
        if inspect.isfunction(obj):
            yield name, obj
        elif inspect.isclass(obj):
            for mname, m in vars(obj).items():
                if inspect.isfunction(m) and (not mname.startswith("_") or mname == "__init__"):
                    yield f"{name}.{mname}", m


@pytest.mark.parametrize("name", MODULES)
def test_public_package_functions_are_annotated(name):
    mod = importlib.import_module(f"selfmanip.{name}")
    missing = []
    for qual, fn in public_callables(mod):
        sig = inspect.signature(fn)
        for p in sig.parameters.values():
            if p.name in ("self", "cls") or p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD):
                continue
            if p.annotation is inspect.Parameter.empty:
                missing.append(f"{qual}({p.name})")
        if sig.return_annotation is inspect.Signature.empty and not qual.endswith("__init__"):
            missing.append(f"{qual} -> ?")
    assert not missing, missing
