"""Sweeps on a Dask cluster (``dask.distributed``): split the points into chunks, run each
chunk with :func:`selfmanip.sweep`'s engine on a worker, merge the tables in input order —
for the RHex leap sweep and for any robot's sweep. :func:`chunks` and :func:`merge` are the
same split and merge for any other pool (joblib, Ray, ``multiprocessing``): recipes in
``docs/python-simulate.md``.

Use it when a sweep has more points than one machine should do — roughly, when
``points x time per leap / local cores`` is longer than you want to wait (hundreds of
thousands of leaps, or parameters with slow leaps) and you have a cluster. On one machine
:func:`selfmanip.sweep` is faster: it runs rayon threads with the GIL released and no
serialization. Results are identical to :func:`selfmanip.sweep` with the same arguments
(every point is independent and deterministic), whatever the chunking or the workers.

The workers need ``selfmanip`` installed (same version). Bring your own client::

    from dask.distributed import Client
    import numpy as np, selfmanip
    client = Client("tcp://scheduler:8786")
    table = selfmanip.distributed.sweep(client, ["++", "+-", "-+", "--"],
                                        t2=np.linspace(-0.2, 0.2, 401),
                                        actuator=[selfmanip.GearedMotor(ratio=g) for g in range(15, 41)])
    robot = selfmanip.Robot.from_file("bounder.toml")            # any robot: a Robot, file or dict
    table = selfmanip.distributed.sweep(client, robot, "bound.toml",
                                        over={"kp_push": np.linspace(20, 60, 41)}, q0=q0)
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Iterable, Mapping

import numpy as np

if TYPE_CHECKING:
    import distributed

import math
import warnings

from . import _facade
from ._facade import DEFAULT
from .errors import AllPointsFailedWarning, InvalidInputError, InvalidTypeError
from .leap import motors_differ, run_points, sweep_points
from .simulation import simulation_sweep, sweep_kind

__all__ = ["sweep", "merge", "chunks"]


def _run_chunk(cols: dict[str, list[Any]], params: Mapping[str, Any] | None, config: Mapping[str, Any],
               threads: int, motor_columns: bool) -> dict[str, np.ndarray]:
    return run_points(cols, params, threads=threads, motor_columns=motor_columns, **dict(config))


def chunks(over: Mapping[str, Any], chunk_size: int) -> list[dict[str, list[Any]]]:
    """A robot sweep's grid ``over`` (``{name: values}``, the last name varying fastest, as in
    :func:`selfmanip.sweep`) split into sub-grids of at most ``chunk_size`` points (at least
    one value of the first name each), in order: :func:`merge` of their sweep tables is the
    whole sweep's table, bit for bit."""
    _positive("chunk_size", chunk_size)
    if not isinstance(over, Mapping):
        raise InvalidTypeError(f"`over` must be a dict of name: values, got {type(over).__name__}", "over")
    axes = [(name, _values(values)) for name, values in over.items()]
    if not axes:
        return [{}]
    (first, values), rest = axes[0], axes[1:]
    inner = math.prod(len(v) for _, v in rest)
    step = max(1, chunk_size // max(1, inner))
    return [{first: values[a:a + step], **dict(rest)} for a in range(0, len(values), step)]


def _values(values: Any) -> list[Any]:
    if isinstance(values, (str, bytes, Mapping)) or np.ndim(values) == 0:
        return [values]
    return list(np.asarray(values, dtype=object).ravel()) if isinstance(values, np.ndarray) else list(values)


def _positive(field: str, value: Any) -> None:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise InvalidInputError(f"`{field}` must be a positive int, got {value!r}", field)


def _run_robot_chunk(args: tuple[Any, ...], kwargs: Mapping[str, Any]) -> dict[str, np.ndarray]:
    """One chunk of a robot sweep on a worker (the all-failed warning is given once, after
    the merge)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AllPointsFailedWarning)
        return simulation_sweep(*args, **kwargs)


def merge(tables: Iterable[Mapping[str, np.ndarray]]) -> dict[str, np.ndarray]:
    """Concatenates sweep tables column by column, in the order given."""
    tables = list(tables)
    if not tables:
        raise InvalidInputError("no tables to merge", "tables")
    keys = list(tables[0])
    for t in tables[1:]:
        if list(t) != keys:
            raise InvalidInputError(f"tables have different columns: {keys} vs {list(t)}", "tables")
    return {k: np.concatenate([np.asarray(t[k]) for t in tables]) for k in keys}


def sweep(client: "distributed.Client", *args: Any, chunk_size: int = 1000, threads_per_task: int = 1,
          **kwargs: Any) -> dict[str, np.ndarray]:
    """:func:`selfmanip.sweep` on the Dask cluster behind ``client``: the same arguments and
    the same table, computed in chunks of ``chunk_size`` points, each task using
    ``threads_per_task`` rayon threads (match it to the workers' ``threads_per_worker``).
    The first argument chooses the sweep by :func:`selfmanip.sweep`'s rule: a robot is any
    robot's sweep (:func:`selfmanip.simulation.simulation_sweep`; its grid split by
    :func:`chunks`), a strategy the RHex leap sweep (``actuator=`` as there). Inputs are
    checked here (one point runs locally) before anything is sent."""
    _positive("chunk_size", chunk_size)
    _positive("threads_per_task", threads_per_task)
    if sweep_kind(args, kwargs) == "robot":
        return _robot_sweep(client, args, kwargs, chunk_size, threads_per_task)
    return _leap_sweep(client, *args, chunk_size=chunk_size, threads_per_task=threads_per_task, **kwargs)


def _robot_sweep(client: "distributed.Client", args: tuple[Any, ...], kwargs: dict[str, Any], chunk_size: int,
                 threads: int) -> dict[str, np.ndarray]:
    """Any robot's sweep on the cluster: the grid ``over`` split by :func:`chunks`."""
    names = ("robot", "behaviour", "over")
    call = dict(zip(names, args), **kwargs)
    if len(args) > len(names):
        raise InvalidInputError("give q0 and the options by name", "args")
    over = call.pop("over", None) or {}
    if not isinstance(over, Mapping):
        try:
            over = dict(over)             # (name, values) pairs, as selfmanip.sweep takes them
        except (TypeError, ValueError):
            raise InvalidTypeError("`over` must be a dict of name: values or (name, values) pairs", "over") from None
    call["threads"] = threads
    parts = chunks(over, chunk_size)
    # check the inputs locally (one point), so that bad input fails before submitting
    _run_robot_chunk((), dict(call, over={k: v[:1] for k, v in parts[0].items()}, threads=1))
    futures = client.map(_run_robot_chunk, [()] * len(parts), [dict(call, over=p) for p in parts], pure=False)
    table = merge(client.gather(futures))
    _facade.warn_if_all_failed(table, stacklevel=3)
    return table


def _leap_sweep(client: "distributed.Client", strategy: str | Iterable[str] = "++", t2: Any = 0.0,
                gear_ratio: Any = DEFAULT, params: Mapping[str, Any] | None = None, *, chunk_size: int,
                threads_per_task: int, actuator: Any = DEFAULT, grid: bool = True,
                config: Mapping[str, Any] | None = None, **swept: Any) -> dict[str, np.ndarray]:
    """The RHex leap sweep on the cluster (see :func:`sweep`)."""
    cols = sweep_points(strategy, t2, gear_ratio, actuator=actuator, grid=grid, **swept)
    config = dict(config or {})
    # check the base parameters locally (one point), so a bad base fails before submitting
    one = {k: v[:1] for k, v in cols.items()}
    run_points(one, params, threads=1, **config)
    n = len(cols["strategy"])
    chunks = [{k: v[a:a + chunk_size] for k, v in cols.items()} for a in range(0, n, chunk_size)]
    futures = client.map(_run_chunk, chunks, params=params, config=config, threads=threads_per_task,
                         motor_columns=motors_differ(cols["actuator"]), pure=False)
    table = merge(client.gather(futures))
    _facade.warn_if_all_failed(table, stacklevel=3)
    return table
