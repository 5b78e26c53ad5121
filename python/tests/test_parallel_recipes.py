"""The joblib, Ray and Dask recipes of docs/python-simulate.md ("Parallel runs") run as written
for a user's robot (not an RHex leap), and each gives the serial result bit for bit: the
sweep table of the whole grid run in this process with one thread, and the executions of
``simulate`` run here one by one (their data and their replayed trajectories).

Also: :func:`selfmanip.distributed.chunks` splits any grid so that the merged tables are the
whole grid's, and bad input to the Dask sweep fails before anything is sent."""

from __future__ import annotations

import pathlib
import re

import numpy as np
import pytest

import selfmanip
from selfmanip.distributed import chunks, merge
from selfmanip.errors import InvalidInputError, InvalidTypeError

ROOT = pathlib.Path(__file__).resolve().parents[2]
DATA = ROOT / "crates" / "selfmanip-sim" / "examples" / "data"
DOC = (ROOT / "docs" / "python-simulate.md").read_text(encoding="utf-8")
SECTION = DOC.split("## Parallel runs")[1].split("\n## ")[0].replace("crates/selfmanip-sim/examples/data/",
                                                                     str(DATA) + "/")
SETUP, JOBLIB, RAY, DASK = re.findall(r"```python\n(.*?)```", SECTION, flags=re.S)


def same_tables(a, b) -> None:
    assert list(a) == list(b)
    for k in a:
        x, y = np.asarray(a[k]), np.asarray(b[k])
        assert x.dtype == y.dtype and x.shape == y.shape, k
        assert (x.tobytes() == y.tobytes()) if x.dtype.kind != "O" else list(x) == list(y), k


@pytest.fixture(scope="module")
def setup() -> dict:
    ns: dict = {}
    exec(compile(SETUP, "python-simulate.md", "exec"), ns)
    ns["serial"] = selfmanip.sweep(ns["robot"], ns["behaviour"], ns["over"], q0=ns["q0"], t_final=0.4, threads=1)
    assert len(ns["serial"]["status"]) == 10 and len(ns["parts"]) > 1
    return ns


def run(block: str, setup: dict) -> dict:
    ns = dict(setup)
    exec(compile(block, "python-simulate.md", "exec"), ns)
    return ns


def test_joblib_recipe(setup) -> None:
    pytest.importorskip("joblib")
    ns = run(JOBLIB, setup)
    same_tables(ns["table"], setup["serial"])
    assert len(ns["runs"]) == len(setup["over"]["kp_push"])
    for kp, e in zip(setup["over"]["kp_push"], ns["runs"]):
        here = selfmanip.simulate(setup["robot"], setup["behaviour"], setup["q0"], t_final=0.4,
                                  params={"kp_push": kp})
        assert e._native is None            # came back pickled: data now, replay on demand
        assert (e.status, e.word, e.outcome, e.events) == (here.status, here.word, here.outcome, here.events)
        a, b = e.trajectory(0.002), here.trajectory(0.002)
        for f in ("t_s", "q", "qd", "tau", "contact_points_m", "contact_forces_n"):
            assert getattr(a, f).tobytes() == getattr(b, f).tobytes(), f


def test_ray_recipe(setup) -> None:
    ray = pytest.importorskip("ray")
    try:
        ns = run(RAY, setup)
    finally:
        ray.shutdown()
    same_tables(ns["table"], setup["serial"])


def test_dask_recipe_for_any_robot(setup) -> None:
    pytest.importorskip("distributed")
    ns = run(DASK, setup)
    try:
        same_tables(ns["table"], setup["serial"])
        with pytest.raises(InvalidInputError) as e:
            selfmanip.distributed.sweep(ns["client"], setup["robot"], setup["behaviour"], over={"no_such_name": [1.0]},
                                        q0=setup["q0"])
        assert e.value.field is not None
        with pytest.raises(InvalidInputError):
            selfmanip.distributed.sweep(ns["client"], setup["robot"], setup["behaviour"], over=setup["over"],
                                        q0=setup["q0"], chunk_size=0)
    finally:
        ns["client"].close()


@pytest.mark.parametrize("size", [1, 2, 3, 5, 10, 100])
def test_chunks_cover_the_grid_in_order(size) -> None:
    """The sub-grids, expanded, are the whole grid in its order (last name fastest), each at
    most ``size`` points unless one value of the first name already has more."""
    over = {"a": [1.0, 2.0, 3.0, 4.0, 5.0], "b": ["x", "y"]}
    whole = [(a, b) for a in over["a"] for b in over["b"]]
    parts = chunks(over, size)
    got = [(a, b) for p in parts for a in p["a"] for b in p["b"]]
    assert got == whole
    assert all(len(p["a"]) * len(p["b"]) <= max(size, len(over["b"])) for p in parts)


def test_chunks_name_bad_input() -> None:
    with pytest.raises(InvalidTypeError) as e:
        chunks([("a", [1.0])], 2)
    assert e.value.field == "over"
    with pytest.raises(InvalidInputError) as e:
        chunks({"a": [1.0]}, 0)
    assert e.value.field == "chunk_size"


def test_merge_refuses_different_columns() -> None:
    with pytest.raises(InvalidInputError):
        merge([{"a": np.zeros(1)}, {"b": np.zeros(1)}])
