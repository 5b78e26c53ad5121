"""``selfmanip leap``, ``selfmanip sweep`` and ``selfmanip grc`` (issue 5), and the file
half of ``selfmanip plot`` (a sweep table or a leap → PNG).

Ranges: ``A:B:N`` is ``N`` evenly spaced values from ``A`` to ``B`` inclusive
(``--t2 -0.2:0.2:41``), ``A,B,C`` a list, ``A`` one value; values may start with a minus
sign (``--strategy -+``). ``--set NAME=RANGE`` sweeps any model parameter by name
(``--set m_b=7:9:3``, ``--set leg_shape=half_circle,stick``, ``--set mu_rear=none``); a value
that starts with ``{`` or ``[`` is one JSON value (``--set 'terrain={"kind": "ledge",
"height_m": 0.2, "distance_m": 0.4}'``, ``--set 'pairs=["middle", "rear"]'``).

Exit codes: 0 success; 1 ``sweep`` whose points all failed, or ``sweep --strict`` with any
failed point; 2 bad input (ranges, strategies, parameter names or values, unreadable files)
with a message on stderr; 130 Ctrl-C; 141 the reader of stdout went away (``| head``).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from typing import Any, Mapping

import numpy as np

from . import _native
from ._checks import path_arg
from ._tables import read_table, write_table  # noqa: F401 (read_table: kept importable here)
from .errors import InvalidInputError

PLOT_SUFFIXES = (".csv", ".parquet", ".json", ".mcap")


#: The most values an ``A:B:N`` range holds (the engine's bound on a sweep's grid): checked
#: before numpy is asked for them (``--t2=0:1:1e11`` raised numpy's ArrayMemoryError).
MAX_RANGE_COUNT: int = _native.SIM_MAX_SWEEP_POINTS


def parse_range(text: str, field: str, *, integer_count: bool = True) -> list[float]:
    """``A:B:N`` (inclusive linspace), ``A,B,...`` or ``A`` as floats; ``ValueError``
    naming the option otherwise."""
    s = text.strip()
    if not s:
        raise InvalidInputError(f"`{field}`: empty range", field)
    try:
        if ":" in s:
            parts = s.split(":")
            if len(parts) != 3:
                raise ValueError("expected START:STOP:COUNT")
            a, b = float(parts[0]), float(parts[1])
            n_f = float(parts[2])
            if not n_f.is_integer() or n_f < 1:
                raise ValueError(f"COUNT must be a positive integer, got {parts[2]!r}")
            if n_f > MAX_RANGE_COUNT:
                raise ValueError(f"COUNT {parts[2]} is more than the {MAX_RANGE_COUNT} values a range holds")
            n = int(n_f)
            if n == 1 and a != b:
                raise ValueError("COUNT 1 needs START == STOP")
            vals = [float(v) for v in np.linspace(a, b, n)]
        else:
            vals = [float(v) for v in s.split(",") if v.strip() != ""]
    except ValueError as e:
        raise InvalidInputError(f"`{field}`: bad range {text!r}: {e}", field) from None
    if not vals:
        raise InvalidInputError(f"`{field}`: empty range {text!r}", field)
    bad = [v for v in vals if not math.isfinite(v)]
    if bad:
        raise InvalidInputError(f"`{field}`: values must be finite, got {bad[0]}", field)
    return vals


def _parse_values(name: str, spec: str, option: str = "--set") -> list[Any]:
    """One JSON value when ``spec`` starts with ``{`` or ``[``; otherwise numbers (a range) when
    they parse, else strings; ``none`` is ``None``. Errors name ``{option} {name}``."""
    field = f"{option} {name}"
    if spec.lstrip().startswith(("{", "[")):
        try:
            return [json.loads(spec)]
        except json.JSONDecodeError as e:
            raise InvalidInputError(f"`{field}`: not a JSON value: {e}", field) from None
    try:
        return parse_range(spec, field)
    except ValueError:
        items = [v.strip() for v in spec.split(",") if v.strip()]
        if not items:
            raise InvalidInputError(f"`{field}`: no value", field) from None
        if any(":" in v for v in items):
            return parse_range(spec, field)  # re-raise the range's message
        out: list[Any] = []
        for v in items:
            if v.lower() in ("none", "null"):
                out.append(None)
            elif v.lower() in ("true", "false"):
                out.append(v.lower() == "true")
            else:
                try:
                    out.append(float(v))
                except ValueError:
                    out.append(v)
        return out


#: The leap's inputs that have options of their own: ``--set gear_ratio=28`` reached ``leap()``
#: twice ("got multiple values"); it is refused naming the option to use.
OWN_OPTIONS = {"strategy": "--strategy", "t2": "--t2", "t2_s": "--t2", "gear_ratio": "--gear-ratio",
               "dt": "--dt", "params": "--set NAME=VALUE", "sensitivities": "--sensitivities",
               "grid": "--set", "config": "--set NAME=VALUE"}


def _name_and_spec(item: str, option: str, form: str) -> tuple[str, str]:
    """The stripped name and the text after the first ``=`` of one ``option`` item (``--set``,
    ``--over``) of the ``form`` ``NAME=…``."""
    if "=" not in item:
        raise InvalidInputError(f"`{option}`: expected {form}, got {item!r}", option)
    name, spec = item.split("=", 1)
    return name.strip(), spec


def _sets(items: list[str] | None, own: Mapping[str, str] | None = None) -> dict[str, list[Any]]:
    """``--set NAME=VALUE`` items by name; a name in ``own`` (an input with its own option) or
    a name given twice is refused."""
    out: dict[str, list[Any]] = {}
    for item in items or []:
        name, spec = _name_and_spec(item, "--set", "NAME=VALUE")
        field = f"--set {name}"
        if own and name in own:
            raise InvalidInputError(f"`{field}`: `{name}` is set with {own[name]}, not --set", field)
        if name in out:
            raise InvalidInputError(f"`{field}`: `{name}` is set twice", field)
        out[name] = _parse_values(name, spec)
    return out


def _strategies(text: str) -> list[str]:
    from .leap import _strategy

    items = [s.strip() for s in text.split(",")]
    if not any(items):
        raise InvalidInputError("`--strategy`: no strategy given", "--strategy")
    if not all(items):
        # `--strategy=++,,` ran `++` alone
        raise InvalidInputError(f"`--strategy`: an empty strategy in {text!r}", "--strategy")
    return [_strategy(s, "--strategy") for s in items]


def add_subcommands(sub: "argparse._SubParsersAction") -> None:
    le = sub.add_parser("leap", help="one leap from rest to apex (chapter 3); --json, --mcap FILE")
    le.add_argument("--strategy", default="++", help="++, +-, -+ or -- (front, rear push direction)")
    le.add_argument("--t2", default="0.0", help="rear leg start relative to the front leg (s); negative: rear first")
    le.add_argument("--gear-ratio", default=None,
                    help="gear ratio of the X-RHex motors (default: the engine's default actuator, "
                         "the geared motor with G = 28 and a 20 A limit)")
    le.add_argument("--saturated", action="store_true", help="chapter 3's saturated torque instead of geared motors")
    le.add_argument("--set", action="append", metavar="NAME=VALUE", help="set a parameter by name (repeatable)")
    le.add_argument("--dt", type=float, default=0.002, help="trajectory sample time (s)")
    le.add_argument("--mcap", type=path_arg, help="write the trajectory as an MCAP log (Foxglove)")
    le.add_argument("--json", action="store_true", help="print the result (with the trajectory) as JSON")
    le.set_defaults(leap_handler=leap_command)

    sw = sub.add_parser("sweep", help="many leaps in parallel over strategy x t2 x gear ratio x parameters")
    sw.add_argument("--strategy", default="++", help="comma-separated strategies, e.g. ++,+-")
    sw.add_argument("--t2", default="-0.2:0.2:41", help="range START:STOP:COUNT, list A,B,C or value")
    sw.add_argument("--gear-ratio", default=None,
                    help="range, list or value (default: the engine's default actuator)")
    sw.add_argument("--saturated", action="store_true", help="chapter 3's saturated torque instead of geared motors")
    sw.add_argument("--set", action="append", metavar="NAME=RANGE", help="sweep a parameter by name (repeatable)")
    sw.add_argument("--sensitivities", default=None, metavar="NAMES",
                    help="comma-separated parameters (t2, gear_ratio, m_b, I_b): adds the columns "
                         "d_<apex column>/d_<name> and sensitivity_ok")
    sw.add_argument("--threads", type=int, default=None, help="worker threads (default: all CPUs)")
    sw.add_argument("--out", type=path_arg, help="output .csv or .parquet (default: CSV on stdout)")
    sw.add_argument("--progress", choices=["auto", "always", "never"], default="auto",
                    help="progress bar on stderr (auto: when stderr is a terminal)")
    sw.add_argument("--strict", action="store_true",
                    help="exit with status 1 when any leap did not fly (without it: when none flew)")
    sw.set_defaults(leap_handler=sweep_command)

    gr = sub.add_parser("grc", help="the ground reaction complex and the leap grammar (chapter 3)")
    gr.add_argument("--json", action="store_true", help="print the complex as JSON")
    gr.set_defaults(leap_handler=grc_command)


def _scalar_sets(sets: dict[str, list[Any]]) -> dict[str, Any]:
    for k, v in sets.items():
        if len(v) != 1:
            raise InvalidInputError(f"`--set {k}`: a single leap takes one value, got {len(v)}", f"--set {k}")
    return {k: v[0] for k, v in sets.items()}


def _gear_arg(args: argparse.Namespace) -> Any:
    """``--saturated`` → ``None``; ``--gear-ratio`` → its values; neither → the default."""
    from .leap import DEFAULT

    if args.saturated:
        if args.gear_ratio is not None:
            raise InvalidInputError("`--gear-ratio` and `--saturated` exclude each other", "--gear-ratio")
        return None
    if args.gear_ratio is None:
        return DEFAULT
    gears = parse_range(args.gear_ratio, "--gear-ratio")
    for g in gears:
        if g <= 0:
            raise InvalidInputError(f"`--gear-ratio`: must be positive, got {g}", "--gear-ratio")
    return gears


def leap_command(args: argparse.Namespace) -> int:
    from .leap import leap

    t2s = parse_range(args.t2, "--t2")
    if len(t2s) != 1:
        raise InvalidInputError("`--t2`: a single leap takes one value", "--t2")
    t2 = t2s[0]
    gear = _gear_arg(args)
    if isinstance(gear, list):
        if len(gear) != 1:
            raise InvalidInputError("`--gear-ratio`: a single leap takes one value", "--gear-ratio")
        gear = gear[0]
    strategies = _strategies(args.strategy)
    if len(strategies) != 1:
        raise InvalidInputError("`--strategy`: a single leap takes one strategy", "--strategy")
    strategy = strategies[0]
    r = leap(strategy, t2=t2, gear_ratio=gear, dt=args.dt, **_scalar_sets(_sets(args.set, OWN_OPTIONS)))
    if args.mcap:
        r.write_mcap(args.mcap)
    if args.json:
        json.dump(r.to_dict(), sys.stdout)
        sys.stdout.write("\n")
        return 0
    print(f"leap {r.strategy} t2={r.t2_s:g} s "
          f"{'saturated torque' if r.gear_ratio is None else f'gear ratio {r.gear_ratio:g}'}: status {r.status}")
    if r.reason:
        print(f"reason {r.reason}")
    print(f"word {r.word}")
    if r.apex is not None:
        a = r.apex
        print(f"apex t={a.t_s:.4f} s  height z={a.z_m:.4f} m  x={a.x_m:.4f} m  pitch={a.phi_rad:.4f} rad  "
              f"xdot={a.xdot_m_s:.4f} m/s  phidot={a.phidot_rad_s:.4f} rad/s")
    for e in r.events:
        print(f"  t={e['t_s']:+.5f} s  {e['kind']:<9} {e['mode_before']} -> {e['mode_after']}  "
              f"{','.join(e['contacts'])}  dE={e['energy_loss_j']:.4g} J")
    if args.mcap:
        print(f"wrote {args.mcap}")
    return 0


def sweep_command(args: argparse.Namespace) -> int:
    from .leap import run_points, sweep_points

    strategies = _strategies(args.strategy)
    t2 = parse_range(args.t2, "--t2")
    gear = _gear_arg(args)
    sets = _sets(args.set, OWN_OPTIONS)
    if args.threads is not None and args.threads < 1:
        raise InvalidInputError(f"`--threads` must be >= 1, got {args.threads}", "--threads")
    if args.out and not args.out.endswith((".csv", ".parquet")):
        raise InvalidInputError(f"`--out`: expected a .csv or .parquet file, got {args.out!r}", "--out")
    cols = sweep_points(strategies, t2, gear, **sets)
    show = args.progress == "always" or (args.progress == "auto" and sys.stderr.isatty())
    names = None if args.sensitivities is None else [n.strip() for n in args.sensitivities.split(",") if n.strip()]
    table = run_points(cols, threads=args.threads, progress=show, sensitivities=names)
    return finish_sweep(table, args.out, args.strict, done_word="flew")


def finish_sweep(table: Mapping[str, Any], out: str | None, strict: bool, done_word: str) -> int:
    """Writes a sweep table (``out``, or stdout), reports its statuses on stderr (``N points, M
    <done_word>, k <status>…``) and returns the exit code: 1 when no point is done
    (:func:`selfmanip._facade.done`: a leap flew, a run reached its end; saying why) or, with
    ``strict``, when any point is not; else 0."""
    write_table(table, out)
    from . import _facade
    from ._sweep_report import done_points

    status = np.asarray(table["status"]).astype(str)
    is_done = done_points(table, _facade.done(table))
    n_done = int(is_done.sum())
    failed = {s: int(np.sum(status[~is_done] == s)) for s in sorted(set(status[~is_done].tolist()))}
    print(f"selfmanip sweep: {len(status)} points, {n_done} {done_word}"
          + ("" if not failed else ", " + ", ".join(f"{v} {k}" for k, v in failed.items()))
          + (f"; wrote {out}" if out else ""), file=sys.stderr)
    all_failed = _facade.failure_summary(table)
    if all_failed is not None:
        print(f"selfmanip sweep: error: {all_failed}", file=sys.stderr)
        return 1
    return 1 if (strict and failed) else 0


def grc_command(args: argparse.Namespace) -> int:
    from . import _native
    from .rhex import ground_reaction_complex

    g = ground_reaction_complex()
    if args.json:
        json.dump(g, sys.stdout, indent=1)
        sys.stdout.write("\n")
        return 0
    sites = g["sites"]
    print(f"Ground reaction complex (chapter 3): {len(g['cells'])} cells over the sites {' '.join(sites)}")
    print(f"{'cell':<6}{'dof':>4}  contacts")
    for c in g["cells"]:
        print(f"{c['label']:<6}{str(c['dof']):>4}  {', '.join(c['contacts']) or '(flight)'}"
              + ("  fully constrained" if c.get("fully_constrained") else ""))
    print(f"\nAllowable transitions (Fig. 3.3): {len(g['allowable'])}")
    for t in g["allowable"]:
        print(f"  {t['from']} -> {t['to']}  {'touchdown' if t['touchdown'] else 'liftoff'} of "
              f"{sites[t['site']]}  ({t['category']})")
    print()
    print(_native.leap_grammar_text(), end="")
    print(f"Strategies (front, rear): {', '.join(g['strategies'])}")
    return 0


def is_data_file(target: str) -> bool:
    return target.lower().endswith(PLOT_SUFFIXES)


def plot_command(target: str, out: str) -> int:
    from .plots import plot_file

    print(plot_file(target, out))
    return 0
