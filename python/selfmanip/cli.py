"""The ``selfmanip`` command (also ``python -m selfmanip``).

``selfmanip chapter3`` (the default: the main job) runs chapter 3's leap sweep — four
strategies over the coordination time t2 — and writes it as a table and a figure
(``chapter3.py``); ``selfmanip demo`` runs the chapter-4 RHex model end to end on built-in
defaults and prints a readable report; ``selfmanip dynamics`` evaluates (5.3)-(5.4) at one state;
``selfmanip map`` writes the quasi-static contact-mode map (Fig. 4.3/4.6) as CSV;
``selfmanip motor`` prints the motor/gearbox table (Tables 2.2-2.3) and a thermal simulation
(Fig. 2.8); ``selfmanip analysis`` prints the data behind the section-4.3 figures and
``selfmanip plot fig4.8 --out f.png`` draws one; ``selfmanip leap``, ``selfmanip sweep`` and
``selfmanip grc`` run one leap, parallel sweeps of leaps and print the ground reaction complex
(``cli_leap.py``; ``selfmanip plot FILE.csv|.parquet|.json|.mcap`` draws their results);
``selfmanip simulate ROBOT BEHAVIOUR`` and ``selfmanip sweep --robot ROBOT …`` run any robot
(``cli_sim.py``); ``selfmanip calibrate DATA.csv --fit NAME=LO:HI … --out DIR`` fits a
preset's parameters to measured runs (``cli_calibrate.py``).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from typing import Sequence

import numpy as np

from ._checks import path_arg
from ._tables import write_atomically
from .errors import InvalidInputError, SelfmanipError
from .rhex import Model

_SUPPORT_GLYPH = {("B", "B"): ".", ("B", "R"): "r", ("B", "T"): "t", ("R", "B"): "R", ("T", "B"): "T",
                  ("R", "R"): "o", ("R", "T"): "/", ("T", "R"): "\\", ("T", "T"): "#"}


def _floats(text: str) -> list[float]:
    try:
        return [float(v) for v in text.split(",") if v.strip()]
    except ValueError as e:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers: {e}") from e


def demo(out=None) -> int:
    """The chapter-4 RHex, end to end."""
    out = out or sys.stdout
    p = print
    m = Model()
    prm = m.params
    p("selfmanip demo: the chapter-4 RHex (Table 4.2, massless half-circle legs)", file=out)
    p(f"  m_b={prm['m_b']} kg  I_b={prm['I_b']} kg m^2  l={prm['l1']} m  rho={prm['rho1']} m  "
      f"rho_b={prm['rho_b']} m  tau_s={prm['tau_s']} N m", file=out)
    p("  frames: North-East-Down (z down, phi nose-up); lam = ground force on robot, normal into ground", file=out)

    # 1. standing on both toes, pushing: (5.3)-(5.4) and Result C.1 (4.60)
    theta, tau = 0.4, 0.1 * prm["tau_s"]
    q = [theta, theta, 0.0, -prm["rho1"] * math.cos(theta), 0.0]
    d = m.dynamics("0101", q, [0.0] * 5, [tau, tau])
    p(f"\n[1] stance 0101 at theta1=theta2={theta} rad, tau={tau} N m on both legs", file=out)
    p(f"    qdd = {np.array2string(d.qdd, precision=4)}  (theta1, theta2, x, z, phi)", file=out)
    p(f"    lam = {np.array2string(d.lam, precision=3)}  rows {[r[0] + '.' + r[1][0] for r in d.rows]}", file=out)
    diff = d.lam[1] - d.lam[3]
    p(f"    Result C.1: rear-front toe push {diff:.6f} N vs 2 tau / l = {2 * tau / prm['l1']:.6f} N", file=out)

    # 2. the KKT blocks
    k = m.kkt("0101", q)
    p(f"\n[2] KKT (5.2): A is {k.A.shape[0]}x{k.A.shape[1]}, constraint condition "
      f"{k.constraint_condition:.2f}, eig(Lambda) = {np.array2string(np.linalg.eigvalsh(k.Lambda), precision=3)}",
      file=out)

    # 3. landing: plastic impact from flight onto both legs
    qd = [0.0, 0.0, 0.3, 1.0, -0.5]
    ke0, _ = m.energy(q, qd)
    imp = m.impact("0101", q, qd)
    ke1, _ = m.energy(q, imp.qd_plus)
    p(f"\n[3] plastic impact (5.10) landing at z' = 1 m/s: kinetic energy {ke0:.3f} J -> {ke1:.3f} J, "
      f"impulse {np.array2string(imp.impulse, precision=3)} N s", file=out)

    # 4. the quasi-static contact-mode map and Result B.1
    n = 36
    cm = m.contact_mode_map(n)
    p(f"\n[4] quasi-static supports over the joint torus (Fig. 4.3), theta1 down, theta2 across, "
      f"[-pi, pi) on {n}x{n}:", file=out)
    p("    front/rear support: . body/body  # toe/toe  o roll/roll  T toe/body  R roll/body  "
      "t body/toe  r body/roll  / roll/toe  \\ toe/roll", file=out)
    for i in range(n):
        p("    " + "".join(_SUPPORT_GLYPH.get((cm.front[i, j], cm.rear[i, j]), " ") for j in range(n)), file=out)
    phi_max = np.nanmax(cm.phi)
    b1 = math.asin((prm["rho1"] - prm["rho_b"]) / (prm["l1"] + prm["l2"]))
    p(f"    largest pitch on this grid {math.degrees(phi_max):.2f} deg; Result B.1 bound "
      f"arcsin((rho-rho_b)/2l) = {math.degrees(b1):.2f} deg", file=out)

    # 5. speed of one evaluation through Python
    reps = 20000
    t0 = time.perf_counter()
    for _ in range(reps):
        m.dynamics("0101", q, qd, [tau, tau])
    dt = (time.perf_counter() - t0) / reps
    p(f"\n[5] {dt * 1e6:.1f} us per dynamics call from Python (the Rust core alone: see `cargo bench --bench kkt`)",
      file=out)
    return 0


def _dynamics(args) -> int:
    m = Model()
    d = m.dynamics(args.mode, args.q, args.qd, args.tau)
    print(f"mode {d.mode}")
    print("qdd " + " ".join(f"{v:.9g}" for v in d.qdd))
    for (contact, direction), v in zip(d.rows, d.lam):
        print(f"lam {contact} {direction} {v:.9g}")
    if d.free_joints:
        print(f"free massless joints (prescribed qdd): {d.free_joints}")
    return 0


def _map(args) -> int:
    cm = Model().contact_mode_map(args.n)

    def emit(out) -> None:
        out.write("theta1_rad,theta2_rad,phi_rad,height_m,front,rear,label\n")
        for i in range(args.n):
            for j in range(args.n):
                out.write(f"{cm.theta1[i, j]:.12g},{cm.theta2[i, j]:.12g},{cm.phi[i, j]:.12g},"
                          f"{cm.height_m[i, j]:.12g},{cm.front[i, j]},{cm.rear[i, j]},{cm.label[i, j]}\n")

    if args.csv:
        def emit_file(tmp: str) -> None:
            with open(tmp, "w", encoding="utf-8") as f:
                emit(f)

        write_atomically(args.csv, emit_file)
    else:
        emit(sys.stdout)
    return 0


def _motor(args) -> int:
    from . import motor

    for name in ("dt", "every"):
        if not getattr(args, name) > 0:
            raise InvalidInputError(f"`--{name}` must be > 0, got {getattr(args, name)}", f"--{name}")
    for name in ("duration", "cooling"):
        if not getattr(args, name) >= 0:
            raise InvalidInputError(f"`--{name}` must be >= 0, got {getattr(args, name)}", f"--{name}")
    samples = (args.duration + args.cooling) / args.dt
    if not samples <= motor.MAX_PROFILE_SAMPLES:
        raise InvalidInputError(
            f"`--duration` + `--cooling` over `--dt` is {samples:.3g} samples, more than the "
            f"{motor.MAX_PROFILE_SAMPLES} a thermal simulation runs: raise --dt or shorten the run",
            "--duration")
    n_on = int(round(args.duration / args.dt))
    n_off = int(round(args.cooling / args.dt))
    profile = np.concatenate([np.full(n_on, args.torque), np.zeros(n_off)])
    sim = motor.thermal_simulation(args.drive, profile, dt_s=args.dt, ambient_c=args.ambient, case=args.case)
    rows = motor.drive_table(current_limit_a=args.current_limit)
    rpm = 30.0 / math.pi
    print("motor/gearbox combinations (thesis Tables 2.1-2.3; SI, speeds also in rpm)")
    print(f"{'drive':<15}{'G':>5}{'eta':>6}{'I_max A':>9}{'w0 rad/s':>10}{'(rpm)':>8}{'stall N m':>11}"
          f"{'cont N m':>10}{'P_peak W':>10}{'mass kg':>9}{'H_core':>8}{'H_case':>8}")
    for r in rows:
        print(f"{r['name']:<15}{r['gear_ratio']:>5.0f}{r['efficiency']:>6.2f}{r['current_limit_a']:>9.1f}"
              f"{r['output_no_load_speed_rad_s']:>10.2f}{r['output_no_load_speed_rad_s'] * rpm:>8.1f}"
              f"{r['achievable_output_stall_torque_n_m']:>11.2f}{r['continuous_output_torque_n_m']:>10.2f}"
              f"{r['peak_output_power_w']:>10.1f}{r['mass_kg']:>9.3f}{r.get('h_core_k_per_n2m2', float('nan')):>8.1f}"
              f"{r.get('h_case_k_per_n2m2', float('nan')):>8.1f}")
    print("H: heat coefficients in K/(N m)^2 of ideal output torque (Table 2.3, measured case)")
    print(f"\nthermal simulation: {args.drive}, {args.torque} N m at the output for {args.duration:g} s, "
          f"then {args.cooling:g} s cooling; ambient {args.ambient} C, {args.case} case parameters")
    print(f"{'t s':>8}{'core C':>10}{'case C':>10}")
    step = max(1, int(round(args.every / args.dt)))
    for k in range(0, len(sim["time_s"]), step):
        print(f"{sim['time_s'][k]:>8.0f}{sim['core_c'][k]:>10.2f}{sim['case_c'][k]:>10.2f}")
    on = motor.thermal_simulation(args.drive, np.full(1, args.torque), dt_s=args.dt, ambient_c=args.ambient,
                                  case=args.case)
    if "steady_core_c" in on:
        print(f"steady state at {args.torque} N m: core {on['steady_core_c']:.2f} C, case {on['steady_case_c']:.2f} C")
    cont = motor.continuous_output_torque(args.drive, ambient_c=args.ambient, case=args.case)
    print(f"continuous output torque for a 125 C winding: {cont:.3f} N m")
    return 0


def _chapter3(args) -> int:
    from .chapter3 import run

    if args is None:
        run()
    else:
        run(args.out_dir, n=args.n, saturated=args.saturated, threads=args.threads)
    return 0


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="selfmanip", description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="command")
    c3 = sub.add_parser("chapter3", help="the main job (default): chapter 3's leap sweep, four strategies over t2, "
                        "as a table and a figure (Figs. 3.4-3.5)")
    c3.add_argument("--out-dir", default=".", type=path_arg, help="where chapter3_sweep.csv and chapter3_sweep.png go")
    c3.add_argument("--n", type=int, default=41, help="values of t2 in [-0.2, 0.2] s (default 41)")
    c3.add_argument("--saturated", action="store_true",
                    help="chapter 3's saturated torque (default: the engine's default actuator, the geared motor)")
    c3.add_argument("--threads", type=int, default=None, help="worker threads (default: all cores)")
    sub.add_parser("demo", help="the chapter-4 RHex end to end: dynamics, KKT blocks, an impact, Fig. 4.3's map")
    dy = sub.add_parser("dynamics", help="evaluate (5.3)-(5.4) for the default RHex at one state")
    dy.add_argument("--mode", default="0101", help="chapter-3 label, bits FB FL RB RL (default 0101)")
    dy.add_argument("--q", type=_floats, default=[0.3, 0.3, 0.0, -0.17 * math.cos(0.3), 0.0],
                    help="theta1,theta2,x,z,phi (rad, m; z down)")
    dy.add_argument("--qd", type=_floats, default=[0.0] * 5)
    dy.add_argument("--tau", type=_floats, default=[0.0, 0.0], help="hip torques (N m)")
    mp = sub.add_parser("map", help="quasi-static contact-mode map (Fig. 4.3/4.6) as CSV")
    mp.add_argument("--n", type=int, default=64)
    mp.add_argument("--csv", type=path_arg, help="output file (default: stdout)")
    mo = sub.add_parser("motor", help="motor/gearbox table (Tables 2.2-2.3) and a thermal simulation (Fig. 2.8)")
    mo.add_argument("--drive", default="x-rhex-28", help="research-rhex, x-rhex-18 or x-rhex-28")
    mo.add_argument("--torque", type=float, default=2.0, help="output torque during the run (N m)")
    mo.add_argument("--duration", type=float, default=1800.0, help="run time (s)")
    mo.add_argument("--cooling", type=float, default=1200.0, help="cooling time after the run (s)")
    mo.add_argument("--dt", type=float, default=1.0, help="sample time (s)")
    mo.add_argument("--every", type=float, default=300.0, help="print a row every this many seconds")
    mo.add_argument("--ambient", type=float, default=25.0, help="ambient temperature (C)")
    mo.add_argument("--case", default="measured", choices=["measured", "listed"])
    mo.add_argument("--current-limit", type=float, default=None, help="controller current limit (A)")
    from .cli_analysis import add_subcommands

    add_subcommands(sub)
    from .cli_leap import add_subcommands as add_leap_subcommands

    add_leap_subcommands(sub)
    from .cli_sim import add_subcommands as add_sim_subcommands

    add_sim_subcommands(sub)
    from .cli_calibrate import add_subcommands as add_calibrate_subcommands

    add_calibrate_subcommands(sub)
    pl = sub.add_parser("plot", help="draw a thesis figure as PNG (fig4.3, fig4.6, fig4.8, fig4.10, fig4.11, "
                        "fig4.12), or a sweep table / leap file")
    pl.add_argument("target", help="a figure name, a sweep table (.csv/.parquet) or a leap (.json from "
                    "`selfmanip leap --json`, or .mcap)")
    pl.add_argument("--out", required=True, type=path_arg, help="output PNG path")
    return ap


def _plot(args) -> int:
    from .figures import FIGURE_NAMES, plot_figure

    from .cli_leap import is_data_file, plot_command

    if is_data_file(args.target):
        return plot_command(args.target, args.out)
    if args.target in FIGURE_NAMES:
        print(plot_figure(args.target, args.out))
        return 0
    print(f"selfmanip: error: unknown figure {args.target!r} (known: {', '.join(FIGURE_NAMES)})", file=sys.stderr)
    return 2


def _value_options(parser: argparse.ArgumentParser) -> tuple[set[str], set[str]]:
    """``(options that take one value, every option string)`` of ``parser`` and its
    subcommands."""
    takes, every = set(), set()
    for action in parser._actions:
        every.update(action.option_strings)
        if action.option_strings and action.nargs is None and action.const is None:
            takes.update(action.option_strings)
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                t, e = _value_options(sub)
                takes |= t
                every |= e
    return takes, every


def attach_dash_values(argv: Sequence[str], parser: argparse.ArgumentParser) -> list[str]:
    """Joins ``--option VALUE`` into ``--option=VALUE`` when the value starts with a dash
    (``--strategy -+``, ``--strategy --``, ``--t2 -0.2:0.2:41``), which argparse would
    otherwise take for an option of its own (or, for ``--``, the end of the options)."""
    takes, every = _value_options(parser)
    out: list[str] = []
    # argparse drops a value that is exactly "--" (its end-of-options marker), even after "=":
    # the strategy (-, -) is passed in its other spelling
    args = ["--strategy=- -" if a == "--strategy=--" else a for a in argv]
    i = 0
    while i < len(args):
        a = args[i]
        nxt = args[i + 1] if i + 1 < len(args) else None
        if a == "--strategy" and nxt == "--":
            nxt = "- -"
        if a in takes and nxt is not None and nxt.startswith("-") and nxt.split("=", 1)[0] not in every:
            out.append(f"{a}={nxt}")
            i += 2
            continue
        out.append(a)
        i += 1
    return out


def _run(args) -> int:
    if args.command is None:
        return _chapter3(None)
    if args.command == "chapter3":
        return _chapter3(args)
    if args.command == "demo":
        return demo()
    if args.command == "dynamics":
        return _dynamics(args)
    if args.command == "map":
        return _map(args)
    if args.command == "motor":
        return _motor(args)
    if args.command == "analysis":
        return args.analysis_handler(args)
    if args.command == "plot":
        return _plot(args)
    if args.command in ("leap", "sweep", "grc", "simulate"):
        return args.leap_handler(args)
    if args.command == "calibrate":
        return args.calibrate_handler(args)
    return 2


#: Exit status when the reader of stdout went away (``selfmanip sweep | head``): 128 + SIGPIPE,
#: what a shell reports for a command killed by a broken pipe.
EXIT_BROKEN_PIPE = 141
#: Exit status on Ctrl-C (128 + SIGINT).
EXIT_INTERRUPTED = 130


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(attach_dash_values(sys.argv[1:] if argv is None else list(argv), parser))
    try:
        return _run(args)
    except BrokenPipeError:
        # the reader closed the pipe: nothing is wrong, and nothing more can be written; point
        # stdout at /dev/null so that the interpreter's final flush stays quiet
        try:
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())
        except (OSError, ValueError):
            pass
        return EXIT_BROKEN_PIPE
    except KeyboardInterrupt:
        print("selfmanip: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except (SelfmanipError, ValueError, TypeError, OSError) as e:
        print(f"selfmanip: error: {e}", file=sys.stderr)
        return 2
