"""Sweeps on a Dask cluster (``dask.distributed``): split the points into chunks, run each
chunk with :func:`selfmanip.sweep`'s engine on a worker, merge the tables in input order.

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
                                        gear_ratio=np.linspace(15, 40, 101))
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Iterable, Mapping

import numpy as np

if TYPE_CHECKING:
    import distributed

from .errors import InvalidInputError
from .leap import DEFAULT, _warn_if_all_failed, run_points, sweep_points

__all__ = ["sweep", "merge"]


def _run_chunk(cols: dict[str, list[Any]], params: Mapping[str, Any] | None, config: Mapping[str, Any],
               threads: int) -> dict[str, np.ndarray]:
    return run_points(cols, params, threads=threads, **dict(config))


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


def sweep(client: "distributed.Client", strategy: str | Iterable[str] = "++", t2: Any = 0.0, gear_ratio: Any = DEFAULT,
          params: Mapping[str, Any] | None = None, *, chunk_size: int = 1000, threads_per_task: int = 1,
          grid: bool = True, config: Mapping[str, Any] | None = None, **swept: Any) -> dict[str, np.ndarray]:
    """:func:`selfmanip.sweep` on the Dask cluster behind ``client``: the same arguments and
    the same table, computed in chunks of ``chunk_size`` points, each task using
    ``threads_per_task`` rayon threads (match it to the workers' ``threads_per_worker``).
    Inputs are checked here, before anything is sent."""
    if isinstance(chunk_size, bool) or not isinstance(chunk_size, int) or chunk_size < 1:
        raise InvalidInputError(f"`chunk_size` must be a positive int, got {chunk_size!r}", "chunk_size")
    if isinstance(threads_per_task, bool) or not isinstance(threads_per_task, int) or threads_per_task < 1:
        raise InvalidInputError(f"`threads_per_task` must be a positive int, got {threads_per_task!r}",
                                "threads_per_task")
    cols = sweep_points(strategy, t2, gear_ratio, grid=grid, **swept)
    config = dict(config or {})
    # check the base parameters locally (one point), so a bad base fails before submitting
    one = {k: v[:1] for k, v in cols.items()}
    run_points(one, params, threads=1, **config)
    n = len(cols["strategy"])
    chunks = [{k: v[a:a + chunk_size] for k, v in cols.items()} for a in range(0, n, chunk_size)]
    futures = client.map(_run_chunk, chunks, params=params, config=config, threads=threads_per_task,
                         pure=False)
    table = merge(client.gather(futures))
    _warn_if_all_failed(table)
    return table
