"""The docstring examples of every module of the package run as written."""

import doctest
import importlib
import sys

import pytest

MODULES = ["leap", "actuator", "robot", "rhex", "motor", "plots", "analysis", "errors"]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    if name == "plots":
        pytest.importorskip("matplotlib")
    mod = importlib.import_module(f"selfmanip.{name}")
    assert sys.modules[f"selfmanip.{name}"] is mod
    res = doctest.testmod(mod, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert res.failed == 0
