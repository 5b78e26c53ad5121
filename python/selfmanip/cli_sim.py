"""``selfmanip simulate`` and ``selfmanip sweep --robot …``: any robot, any behaviour.

``selfmanip simulate ROBOT.toml BEHAVIOUR.toml --q0 A,B,… [--qd0 …] [--terrain T]
[--t-final S] [--stop-at apex] [--contacts foot] [--set NAME=VALUE] [--mcap F] [--plot F]
[--json]`` runs one execution and prints its status, word and events (``--json``: the
outcome, events and energy report as JSON). ``BEHAVIOUR`` may be ``none`` (no actuation).

``selfmanip sweep --robot ROBOT.toml --behaviour B.toml --q0 … --over NAME=A:B:N …`` sweeps
named parameters (behaviour parameters, description/terrain/option fields by path) as a grid
and writes the table as CSV (stdout or ``--out F.csv``) or Parquet (``--out F.parquet``), with
the progress bar and exit codes of the RHex sweep.

``--terrain``: ``flat``, a JSON object (``'{"kind": "ledge", "height_m": 0.04,
"distance_m": 0.5}'``) or ``KIND,KEY=VALUE,…`` (``ledge,height_m=0.04,distance_m=0.5``).

Exit codes: 0 success; 1 a sweep whose points all failed (or ``--strict`` with any failed
point), or a simulation that the engine stopped short of its end (Zeno, a budget, no contact
solution, …); 2 bad input (files, names, values) with a message naming the field on stderr;
130 Ctrl-C; 141 the reader of stdout went away.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import TYPE_CHECKING, Any

import numpy as np

from .cli_leap import _name_and_spec, _parse_values, _sets, finish_sweep, write_table
from ._checks import path_arg
from .errors import InvalidInputError

if TYPE_CHECKING:
    from .simulation import Execution


def parse_terrain(text: str | None) -> Any:
    """``--terrain`` as the value :func:`selfmanip.simulate` takes."""
    if text is None:
        return None
    s = text.strip()
    if s.startswith("{"):
        try:
            return json.loads(s, object_pairs_hook=_once_each)
        except json.JSONDecodeError as e:
            raise InvalidInputError(f"`--terrain`: not a JSON object: {e}", "--terrain") from None
    kind, *rest = [p.strip() for p in s.split(",") if p.strip()] or [""]
    if not kind:
        raise InvalidInputError("`--terrain`: empty", "--terrain")
    if not rest:
        return kind
    out: dict[str, Any] = {"kind": kind}
    for item in rest:
        if "=" not in item:
            raise InvalidInputError(f"`--terrain`: expected KEY=VALUE, got {item!r}", "--terrain")
        k, v = item.split("=", 1)
        if k.strip() in out:
            raise InvalidInputError(f"`--terrain {k.strip()}`: given twice", f"--terrain {k.strip()}")
        try:
            out[k.strip()] = int(v) if k.strip() == "count" else float(v)
        except ValueError:
            raise InvalidInputError(f"`--terrain {k.strip()}`: not a number: {v!r}", f"--terrain {k.strip()}") from None
    return out


def _once_each(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """A JSON object whose keys are given once each (``json.loads`` keeps the last of a
    repeated key, silently)."""
    out: dict[str, Any] = {}
    for k, v in pairs:
        if k in out:
            raise InvalidInputError(f"`--terrain {k}`: given twice", f"--terrain {k}")
        out[k] = v
    return out


def _vector(text: str | None, field: str) -> list[float] | None:
    if text is None:
        return None
    try:
        vals = [float(v) for v in text.split(",") if v.strip()]
    except ValueError as e:
        raise InvalidInputError(f"`{field}`: expected comma-separated numbers: {e}", field) from None
    if not vals:
        raise InvalidInputError(f"`{field}`: no values", field)
    return vals


def _behaviour(text: str | None) -> str | None:
    return None if text is None or text.lower() == "none" else text


def _scalar_sets(items: list[str] | None) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for name, vals in _sets(items).items():
        if len(vals) != 1:
            raise InvalidInputError(f"`--set {name}`: one value, got {len(vals)}", f"--set {name}")
        out[name] = vals[0]
    return out


def _common(p: argparse.ArgumentParser, *, sweep: bool) -> None:
    req = not sweep
    if sweep:
        p.add_argument("--q0", default=None, help="initial q: joint angles..., x, z, phi (rad, m; z down)")
    else:
        p.add_argument("--q0", required=req, help="initial q: joint angles..., x, z, phi (rad, m; z down)")
    p.add_argument("--qd0", default=None, help="initial qd (default: at rest)")
    p.add_argument("--terrain", default=None, help="flat, KIND,KEY=VALUE,... or a JSON object")
    p.add_argument("--t-final", type=float, default=None, help="end of the execution (s; default: the engine's)")
    p.add_argument("--stop-at", choices=["apex"], default=None, help="stop at the first apex of a flight")
    p.add_argument("--contacts", default=None, help="contacts active at the start (comma-separated)")
    p.add_argument("--solve", default=None, help="coordinates to solve so that the initial contacts touch")


def add_subcommands(sub: "argparse._SubParsersAction") -> None:
    si = sub.add_parser("simulate", help="one execution of any robot with a behaviour file; --mcap F, --plot F")
    si.add_argument("robot", help="robot description (.toml or .json)")
    si.add_argument("behaviour", help="behaviour file (.toml or .json), or `none` for no actuation")
    _common(si, sweep=False)
    si.add_argument("--set", action="append", metavar="NAME=VALUE", help="set a parameter by name (repeatable)")
    si.add_argument("--dt", type=float, default=None, help="sample interval of the MCAP log and plot (s)")
    si.add_argument("--mcap", type=path_arg, help="write an MCAP log (Foxglove)")
    si.add_argument("--plot", type=path_arg, help="write a PNG plot of the execution")
    si.add_argument("--json", action="store_true", help="print the outcome, events and energy report as JSON")
    si.set_defaults(leap_handler=simulate_command)

    # the RHex sweep's parser gains the options of a sweep of any robot
    sw = sub.choices["sweep"]
    sw.add_argument("--robot", default=None, help="sweep this robot (a description file) instead of RHex leaps")
    sw.add_argument("--behaviour", default=None, help="with --robot: the behaviour file (default: no actuation)")
    sw.add_argument("--over", action="append", metavar="NAME=RANGE",
                    help="with --robot: sweep a parameter by name, A:B:N, A,B,C or a value (repeatable)")
    _common(sw, sweep=True)
    rhex_handler = sw.get_default("leap_handler")

    def dispatch(args: argparse.Namespace) -> int:
        if args.robot is not None:
            return sweep_command(args)
        for opt in ("behaviour", "over", "q0", "qd0", "terrain", "t_final", "stop_at", "contacts", "solve"):
            if getattr(args, opt) is not None:
                flag = "--" + opt.replace("_", "-")
                raise InvalidInputError(f"`{flag}` needs `--robot` (a sweep of your own robot)", flag)
        return rhex_handler(args)

    sw.set_defaults(leap_handler=dispatch)


def _scenario_kwargs(args: argparse.Namespace) -> dict[str, Any]:
    from .leap import DEFAULT

    return dict(qd0=_vector(args.qd0, "--qd0"), terrain=parse_terrain(args.terrain),
                t_final=DEFAULT if args.t_final is None else args.t_final,
                stop_at=DEFAULT if args.stop_at is None else args.stop_at,
                contacts=args.contacts, solve=args.solve)


def print_execution(e: Execution) -> None:
    """Prints what ``selfmanip simulate`` reports of a run: its status and end, the word, each
    event (time, kind, modes, contacts, energy lost), the first apex and the energy account."""
    print(f"{e.robot_name}: status {e.status} at t={e.t_end_s:.6g} s, {len(e.events)} events")
    print(f"word {e.word_string}")
    for ev in e.events:
        print(f"  t={ev['t_s']:.6f} s  {ev['kind']:<9} {ev['mode_before']} -> {ev['mode_after']}  "
              f"{','.join(ev['contacts'])}  dE={ev['energy_loss_j']:.4g} J")
    if e.apex is not None:
        print(f"apex t={e.apex['t_s']:.4f} s  height -z={-e.apex['z_m']:.4f} m  x={e.apex['x_m']:.4f} m")
    er = e.energy_report()
    print(f"energy E0={er.initial_j:.6g} J  E1={er.final_j:.6g} J  work W={er.joint_work_j:.6g} J  "
          f"damping W_d={er.damping_work_j:.6g} J  friction W_fr={er.friction_work_j:.6g} J  "
          f"impact loss L={er.impact_loss_j:.6g} J  residual {er.residual_j:.2e} J")


def simulate_command(args: argparse.Namespace) -> int:
    from .leap import DEFAULT
    from .simulation import simulate

    q0 = _vector(args.q0, "--q0")
    try:
        e = simulate(args.robot, _behaviour(args.behaviour), q0, params=_scalar_sets(args.set),
                     **_scenario_kwargs(args))
    except InvalidInputError as err:
        # the engine names the terrain's fields as simulate's `terrain`: here they came from `--terrain`
        if args.terrain is not None and (err.field or "").startswith("terrain"):
            raise InvalidInputError(f"`--terrain`: {err}", "--" + err.field) from None
        raise
    dt = DEFAULT if args.dt is None else args.dt
    if args.mcap:
        e.to_mcap(args.mcap, dt=dt)
    if args.plot:
        e.plot(args.plot, dt=dt)
    if args.json:
        er = e.energy_report()
        json.dump({"outcome": e.outcome, "events": e.events, "segments": e.segments,
                   "energy": er.__dict__}, sys.stdout)
        sys.stdout.write("\n")
    else:
        print_execution(e)
        for f in (args.mcap, args.plot):
            if f:
                print(f"wrote {f}")
    if not e.complete:
        print(f"selfmanip simulate: the engine stopped the run: {e.status}", file=sys.stderr)
        return 1
    return 0


def _over(items: list[str] | None) -> dict[str, list[Any]]:
    out: dict[str, list[Any]] = {}
    for item in items or []:
        name, spec = _name_and_spec(item, "--over", "NAME=RANGE")
        out[name] = _parse_values(name, spec, "--over")
    if not out:
        raise InvalidInputError("`--over`: give at least one NAME=RANGE", "--over")
    return out


def sweep_command(args: argparse.Namespace) -> int:
    from .simulation import simulation_sweep

    if args.q0 is None:
        raise InvalidInputError("`--q0` is required with `--robot`", "--q0")
    if args.saturated or args.gear_ratio is not None:
        raise InvalidInputError("`--gear-ratio`/`--saturated` are RHex leap options; with `--robot` sweep the "
                                "behaviour's actuator fields by name", "--gear-ratio")
    if args.threads is not None and args.threads < 1:
        raise InvalidInputError(f"`--threads` must be >= 1, got {args.threads}", "--threads")
    if args.out and not args.out.endswith((".csv", ".parquet")):
        raise InvalidInputError(f"`--out`: expected a .csv or .parquet file, got {args.out!r}", "--out")
    # `--set NAME=RANGE` sweeps as in the RHex sweep; `--over` is its name for any robot
    over = {**_sets(args.set), **(_over(args.over) if args.over or not args.set else {})}
    show = args.progress == "always" or (args.progress == "auto" and sys.stderr.isatty())
    import warnings

    from .errors import AllPointsFailedWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AllPointsFailedWarning)  # reported below with the exit code
        table = simulation_sweep(args.robot, _behaviour(args.behaviour), over, q0=_vector(args.q0, "--q0"),
                                 threads=args.threads, progress=show,
                                 **_scenario_kwargs(args))
    return finish_sweep(table, args.out, args.strict, done_word="complete")


__all__ = ["add_subcommands", "parse_terrain", "print_execution", "simulate_command", "sweep_command"]
