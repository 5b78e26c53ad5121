"""The main job: thesis chapter 3's leap sweep (Figs. 3.4-3.5) on the default model.

Every strategy of section 3.3 over the coordination time ``t2`` in [-0.2, 0.2] s, each leap
from rest to its apex through the hybrid engine, read off as apex height, forward
displacement and pitch with the leap word of each point, written as a table and a figure:

    python3 -m selfmanip chapter3 [--out-dir .] [--n 41] [--saturated]

The same as ``selfmanip sweep --strategy ++,+-,-+,-- --t2=-0.2:0.2:41 --out chapter3_sweep.csv``
followed by ``selfmanip plot chapter3_sweep.csv --out chapter3_sweep.png``. How the default
model's leaps compare with the thesis's account, claim by claim: ``docs/fidelity.md``.
"""

from __future__ import annotations

import os
from collections import Counter
from typing import Any, Callable

import numpy as np

from ._facade import DEFAULT
from .actuator import GearedMotor, Saturated
from .errors import InvalidInputError, InvalidTypeError

__all__ = ["STRATEGIES", "run", "summary"]

#: The four strategies of section 3.3, in the thesis's order.
STRATEGIES = ("++", "+-", "-+", "--")


def summary(table: dict[str, Any], n: int) -> list[str]:
    """Lines describing a chapter-3 sweep: per strategy, how many leaps reach an apex, the
    highest and the longest, and the most frequent leap words (labelled by the thesis's
    equations where they are chapter 3's words)."""
    from .plots import word_label

    lines = []
    for s in STRATEGIES:
        m = (table["strategy"] == s) & table["flew"]
        line = f"({s[0]}, {s[1]}): {int(m.sum())}/{n} leaps reach an apex"
        if m.any():
            hi = int(np.argmax(np.where(m, table["apex_z_m"], -np.inf)))
            far = int(np.argmax(np.where(m, np.abs(table["apex_x_m"]), -np.inf)))
            line += (f"; highest {table['apex_z_m'][hi]:.3f} m at t2 = {table['t2_s'][hi]:+.3f} s, "
                     f"longest {table['apex_x_m'][far]:+.3f} m at t2 = {table['t2_s'][far]:+.3f} s")
        lines.append(line)
        for word, count in Counter(table["word"][m]).most_common(4):
            lines.append(f"    {count:3d} x {word_label(word)}")
        failed = Counter(table["status"][(table["strategy"] == s) & ~table["flew"]])
        if failed:
            lines.append("    no apex: " + ", ".join(f"{k} {v}" for k, v in sorted(failed.items())))
    return lines


def _actuator(saturated: bool, actuator: Any) -> tuple[Any, str, str]:
    """The job's actuator (``saturated=True`` is the shorthand for ``Saturated()``), with its
    name in the report and in the figure's title."""
    if saturated and actuator is not DEFAULT:
        raise InvalidInputError("give `actuator` or its shorthand `saturated`, not both", "saturated")
    if saturated or isinstance(actuator, Saturated):
        return Saturated(), "saturated torque (chapter 3)", "(saturated torque)"
    if actuator is DEFAULT:
        return DEFAULT, "the default geared motor", "(default model: geared X-RHex motors)"
    if not isinstance(actuator, GearedMotor):
        raise InvalidTypeError("`actuator` must be selfmanip.Saturated() or selfmanip.GearedMotor(...), got "
                               f"{type(actuator).__name__} {actuator!r}", "actuator")
    return actuator, repr(actuator), f"({actuator!r})"


def run(out_dir: str | os.PathLike = ".", n: int = 41, saturated: bool = False,
        threads: int | None = None, echo: Callable[[str], None] = print, *, actuator: Any = DEFAULT) -> dict[str, Any]:
    """Runs the chapter-3 sweep (``n`` values of ``t2`` in [-0.2, 0.2] s, four strategies) on
    the default model — with ``actuator`` (:mod:`selfmanip.actuator`; left out, the engine's
    default actuator, the geared X-RHex motor; ``saturated=True`` is the shorthand for
    chapter 3's ``Saturated()``) — writes ``chapter3_sweep.csv`` and ``chapter3_sweep.png``
    into ``out_dir``, reports through ``echo`` and returns the table."""
    import selfmanip

    from .cli_leap import write_table
    from .plots import INSTALL_HINT, PlottingUnavailableError, sweep_figure

    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise selfmanip.errors.InvalidInputError(f"n: expected a positive whole number of t2 values, got {n!r}")
    parent = os.path.dirname(os.path.abspath(out_dir))
    if not os.path.isdir(parent):
        # the job makes its own folder, not a tree of them from a mistyped path
        raise selfmanip.errors.InvalidInputError(
            f"out_dir: the folder {parent!r} that would hold {out_dir!r} does not exist", "out_dir")
    act, name, title = _actuator(saturated, actuator)
    t2 = np.linspace(-0.2, 0.2, n)
    kwargs: dict[str, Any] = {} if threads is None else {"threads": threads}
    table = selfmanip.sweep(list(STRATEGIES), t2=t2, actuator=act, **kwargs)
    os.makedirs(out_dir, exist_ok=True)
    csv_path = os.path.join(out_dir, "chapter3_sweep.csv")
    png_path = os.path.join(out_dir, "chapter3_sweep.png")
    write_table(table, csv_path)
    try:
        sweep_figure(table, png_path, title="Chapter 3 leap sweep: apex against t2 " + title)
        wrote = f"wrote {csv_path} and {png_path}"
    except PlottingUnavailableError:
        wrote = (f"wrote {csv_path}; no figure: matplotlib is not installed. For {png_path}: {INSTALL_HINT}, "
                 f"then selfmanip plot {csv_path} --out {png_path}")
    echo(f"chapter-3 leap sweep: {len(STRATEGIES)} strategies x {n} values of t2 in [-0.2, 0.2] s, {name}")
    for line in summary(table, n):
        echo(line)
    echo(wrote)
    return table
