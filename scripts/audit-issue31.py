#!/usr/bin/env python3
"""Issue 31's audit: every reproducer of the issue, verbatim where the issue gives one, each in
its own process under a wall-clock limit and an address-space limit (``resource.setrlimit``),
classified by what it ended in:

    typed-error      a ``SelfmanipError`` naming the field (CLI: exit 2, the option named)
    typed-status     a finite result whose failures are typed statuses (a sweep's rows)
    finite-result    a finite result that passes the case's check (an independent route)
    silently-accepted  a result where the input cannot be honoured (a typed error is due)
    wrong-answer     a finite result that fails the case's check
    non-finite       a result holding NaN or inf
    untyped-field    a typed error that names no field, or not the expected one
    generic-error    any other exception (OverflowError, TypeError, ...)
    traceback        a CLI run that printed a Python traceback
    crash            the process died of a signal (SIGSEGV, SIGABRT, a Rust panic's abort)
    out-of-memory    ``MemoryError`` under the address-space limit
    hang             the wall-clock limit passed

A case passes when its class is the one it wants. Usage:

    python3 scripts/audit-issue31.py [--timeout S] [--memory-gb G] [--only SUBSTRING] [--json FILE]

The package under test is the one ``python3 -c 'import selfmanip'`` finds (set PYTHONPATH to
audit another build). Exit status 0 when every case passes, 1 otherwise."""

from __future__ import annotations

import argparse
import json
import os
import resource
import signal
import subprocess
import sys
import tempfile
import textwrap
import time
from dataclasses import dataclass, field

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DATA = os.path.join(ROOT, "crates", "selfmanip-sim", "examples", "data")
MARK = "@@AUDIT@@"
# The CLI's hopper run (its robot, behaviour and initial pose), ahead of each case's options.
HOP_CLI = ["simulate", f"{DATA}/hopper.toml", f"{DATA}/hop.toml", "--q0=0.5,-1,0,-0.451,0"]

# What every Python case sees: the abbreviations.
PRELUDE = f"""
import math, os, sys, pathlib, signal, subprocess, time
import numpy as np
import selfmanip as s
from selfmanip import motor
DATA = {DATA!r}
HOP, HOPB = DATA + "/hopper.toml", DATA + "/hop.toml"
QUAD = DATA + "/quadruped.toml"
q0h = [0.5, -1, 0, -0.451, 0]
P = {{"k_m": 50.0, "a_m": 20.0, "k_p": 10.0, "k_d": 0.5, "k_g": -1.0, "theta_g_rad": 0.0, "delay_s": 0.012}}
LOG = [np.zeros(200)] * 4
def knee(params):
    return {{"parameters": params, "joints": [{{"joint": "leg[1]", "phases": [{{"name": "a",
            "torque": {{"kind": "constant", "torque_n_m": "p"}}}}]}}]}}
def one_leg(links):
    return {{"name": "r", "body": {{"mass_kg": 2.0, "inertia_kg_m2": 0.02}},
            "legs": [{{"name": "leg", "hip_m": [0.0, 0.0], "links": links}}]}}
"""


@dataclass
class Case:
    """One reproducer. ``code`` (Python) leaves its result in ``r``; ``argv`` runs the CLI
    instead. ``want``: ``error`` (typed, naming ``field``), ``result`` (finite, ``check`` true)
    or ``status`` (a sweep table: typed statuses, ``check`` true)."""
    name: str
    item: str
    want: str
    code: str = ""
    argv: list[str] = field(default_factory=list)
    field: str = ""        # a substring of the field the error must name ("" = any field)
    check: str = ""        # a Python expression over `r` (and `out`/`err`/`files` for the CLI)
    setup: str = ""        # Python run before a CLI case, in its working directory
    timeout_scale: float = 1.0   # of --timeout: a case that writes a big file twice gets more


def nested(n: int) -> str:
    return f"d = []\nfor _ in range({n}):\n    d = [d]\n"


CASES: list[Case] = [
    # 1. unbounded recursion
    Case("ten_thousand_nested_parentheses", "1", "error", field="parameters.p",
         code="r = s.simulate(HOP, knee({'p': '(' * 10000 + '1' + ')' * 10000}), q0h, t_final=0.01)"),
    Case("sum_of_a_hundred_thousand_terms", "1", "error", field="parameters.p",
         code="r = s.simulate(HOP, knee({'p': '+'.join(['1'] * 100000)}), q0h, t_final=0.01)"),
    Case("sum_of_thirty_thousand_terms_in_sweep_threads", "1", "status",
         code="r = s.sweep(HOP, knee({'p': '+'.join(['1'] * 30000), 'q': 1.0}), over={'q': [1.0, 2.0, 3.0]},"
              " q0=q0h, t_final=0.01, threads=2)",
         check="list(r['status']) == ['expression'] * 3"),
    Case("chain_of_twenty_thousand_parameters", "1", "error", field="parameters.c",
         code="ps = {f'c{i:05}': f'c{i + 1:05} + 1' for i in range(19999)}; ps['c19999'] = 1.0; ps['p'] = 'c00000'\n"
              "r = s.simulate(HOP, knee(ps), q0h, t_final=0.01)"),
    Case("robot_legs_nested_30000_deep", "1", "error", field="legs",
         code=nested(30000) + "r = s.simulate({'name': 'r', 'body': {'mass_kg': 1.0, 'inertia_kg_m2': 0.1},"
                              " 'legs': d}, None, [0.0, 0.0, 0.0], t_final=0.01)"),
    Case("behaviour_joints_nested_30000_deep", "1", "error", field="joints",
         code=nested(30000) + "r = s.simulate(QUAD, {'joints': d}, [0.0] * 7, t_final=0.01)"),
    Case("cli_behaviour_file_with_10000_nested_parentheses", "1", "error", field="parameters.p",
         setup="open('b.toml', 'w').write('[parameters]\\np = \"' + '(' * 10000 + '1' + ')' * 10000 + '\"\\n'"
               " '[[joints]]\\njoint = \"leg[1]\"\\n[[joints.phases]]\\nname = \"a\"\\n'"
               " 'torque = { kind = \"constant\", torque_n_m = \"p\" }\\n')",
         argv=["simulate", f"{DATA}/hopper.toml", "b.toml", "--q0=0.5,-1,0,-0.451,0", "--t-final=0.01"]),
    # 2. hangs in eigenvalue routines
    Case("leap_gear_ratio_1e308", "2", "error", field="gear_ratio", code="r = s.leap('++', 0, 1e308)"),
    Case("leap_swing_accel_1e308", "2", "error", field="swing_accel",
         code="r = s.leap(swing_accel_rad_s2=1e308)"),
    Case("hopper_launched_at_1e308", "2", "error", field="qd", code="r = s.simulate(HOP, HOPB, q0h, [1e308] * 5)"),
    Case("hopper_launched_at_1e308_max_steps_100", "2", "error", field="max_steps",
         code="r = s.simulate(HOP, HOPB, q0h, [1e308] * 5, max_steps=100)"),
    Case("cli_leap_gear_ratio_1e308", "2", "error", field="gear", argv=["leap", "--gear-ratio=1e308"]),
    Case("periodic_orbit_guess_qd0_1e308", "2", "error", field="qd",
         code="r = s.periodic_orbit(HOP, DATA + '/hop_periodic.toml', q0h, guess_qd0=[1e308] * 5)"),
    # 3. unbounded sizes
    Case("leap_dt_1e-9", "3", "error", field="dt", code="r = s.leap(dt=1e-9)"),
    Case("execution_trajectory_1e-12", "3", "error", field="dt",
         code="r = s.simulate(HOP, HOPB, q0h, t_final=0.6).trajectory(1e-12)"),
    Case("cli_simulate_dt_1e-10_mcap", "3", "error", field="dt",
         argv=[*HOP_CLI, "--dt=1e-10", "--mcap", "x.mcap"], check="not files"),
    Case("torque_speed_curve_points_1e9", "3", "error", field="points",
         code="r = motor.torque_speed_curve('x-rhex-28', points=10**9)"),
    Case("observe_delay_over_dt_1e9", "3", "error", field="delay_s",
         code="r = motor.observe(dict(P, delay_s=1e6), 1e-3, *LOG)"),
    Case("cli_map_n_4096", "3", "error", field="n", argv=["map", "--n=4096"]),
    Case("cli_analysis_fig4_8_n_100000", "3", "error", field="n", argv=["analysis", "fig4.8", "--n=100000"]),
    Case("sweep_threads_1e9", "3", "result",
         code="r = s.sweep('++', t2=[0.0, 0.05], threads=10**9)", check="len(r['status']) == 2"),
    Case("sweep_threads_10000", "3", "result",
         code="r = s.sweep('++', t2=[0.0, 0.05], threads=10000)", check="len(r['status']) == 2"),
    Case("description_with_120k_one_link_legs", "3", "either", field="legs",
         code="legs = [{'name': f'l{i}', 'hip_m': [0.0, 0.0], 'links': [{'length_m': 0.1, 'mass_kg': 0.1,"
              " 'inertia_kg_m2': 0.001}]} for i in range(120000)]\n"
              "r = s.Robot.from_dict({'name': 'r', 'body': {'mass_kg': 1.0, 'inertia_kg_m2': 0.1}, 'legs': legs})",
         check="r.nq == 120003"),
    # 4. a Rust panic
    Case("observe_delay_1e308", "4", "error", field="delay_s",
         code="r = motor.observe(dict(P, delay_s=1e308), 1e-3, *LOG)", check="len(str(err)) < 300"),
    # 5. one bad point in a sweep
    Case("sweep_gear_ratio_1e308_keeps_17_good_points", "5", "status",
         code="r = s.leap.sweep('++', [0.0, 0.05, 0.1], gear_ratio=[20.0, 25.0, 28.0, 1e308, 35.0, 40.0])",
         check="sum(g != 1e308 for g in r['gear_ratio']) == 15 and "
               "not any(f for f, g in zip(r['flew'], r['gear_ratio']) if g == 1e308) and "
               "all(e == '' for e, g in zip(r['error'], r['gear_ratio']) if g != 1e308)"),
    # 6. silently wrong answers
    Case("limp_spring_leg_energy_balance", "6", "result",
         code="import tempfile\n"
              "p = tempfile.mkdtemp() + '/leg.toml'\n"
              "open(p, 'w').write('name = \"leg\"\\ngravity_m_s2 = 9.81\\n[body]\\nmass_kg = 2.0\\ninertia_kg_m2 = 0.02\\n'"
              " '[[legs]]\\nname = \"leg\"\\nhip_m = [0.0, 0.0]\\n[[legs.links]]\\nlength_m = 0.3\\nmass_kg = 0.3\\n'"
              " 'inertia_kg_m2 = 0.002\\nspring = { stiffness_n_m_per_rad = 20.0 }\\n')\n"
              "e = s.simulate(p, None, [0.8, 0.0, -2.0, 0.0], t_final=0.3)\n"
              "r = e.energy_report()",
         check="abs(r.residual_j) < 1e-6"),
    # the Painlevé report of the sampler: the random three-legged robot is not given;
    # its mechanism is — a run that ends at its final time right at an event, sampled last in
    # the segment before the event (here a flight before a touchdown; there a slide that had
    # become inconsistent)
    Case("run_ending_at_an_event_is_sampled_after_it", "6", "result",
         code="t = next(ev['t_s'] for ev in s.simulate(HOP, HOPB, q0h, t_final=0.6).events if ev['kind'] == 'touchdown')\n"
              "e = s.simulate(HOP, HOPB, q0h, t_final=t)\n"
              "r = e.trajectory(0.01)",
         check="np.array_equal(r.qd[-1], e.qd_end) and r.mode[-1] == e.events[-1]['mode_after']"),
    Case("sweep_axes_kp_push_and_parameters_kp_push_alias", "6", "error", field="kp_push",
         code="r = s.sweep(HOP, HOPB, over={'kp_push': [30., 40.], 'parameters.kp_push': [55.]}, q0=q0h)"),
    Case("hopper_placed_at_1e308", "6", "error", field="q", code="r = s.simulate(HOP, HOPB, [1e308] * 5)"),
    Case("contact_gaps_at_1e308", "6", "error", field="q",
         code="r = s.Robot.from_file(QUAD).contact_gaps([1e308] * 7)"),
    Case("forward_kinematics_at_1e308", "6", "error", field="q",
         code="r = s.Robot.from_file(QUAD).forward_kinematics([1e308] * 7)"),
    Case("thermal_simulation_torque_1e308", "6", "error", field="torque_n_m",
         code="r = motor.thermal_simulation('x-rhex-28', [1e308] * 10)"),
    Case("tail_optimum_1e308", "6", "result", code="r = motor.tail_optimum(1e308, 30.0, 0.05, 1.29)",
         check="r['no_load_speed_rad_s'] > 0"),
    Case("cli_motor_torque_1e308", "6", "error", field="torque", argv=["motor", "--torque=1e308"]),
    Case("terrain_flat_with_extra_key", "6", "error", field="terrain",
         code="r = s.simulate(HOP, HOPB, q0h, terrain={'kind': 'flat', 'extra': 1}, t_final=0.01)"),
    Case("cli_terrain_flat_x_1", "6", "error", field="--terrain",
         argv=[*HOP_CLI, "--t-final=0.01", "--terrain=flat,x=1"]),
    Case("cli_terrain_repeated_height_m", "6", "error", field="--terrain",
         argv=[*HOP_CLI, "--t-final=0.01", "--terrain=ledge,height_m=0.1,height_m=0.2,distance_m=0.3"]),
    Case("terrain_json_repeated_height_m", "6", "error", field="terrain",
         code="from selfmanip import cli_sim\n"
              "r = s.simulate(HOP, HOPB, q0h, t_final=0.01, terrain=cli_sim.parse_terrain("
              "'{\"kind\": \"ledge\", \"height_m\": 0.1, \"height_m\": 0.2, \"distance_m\": 0.3}'))"),
    Case("labels_empty", "6", "error", field="labels",
         code="r = s.simulate(HOP, HOPB, q0h, t_final=0.01, labels=[])"),
    Case("mode_spec_commas", "6", "error", field="", code="r = s.Robot.from_file(HOP).mode_spec(',,,')"),
    Case("dynamics_contact_twice", "6", "error", field="",
         code="r = s.Robot.from_file(QUAD).dynamics('fore_foot,fore_foot', [0.3, -0.6, 0.3, -0.6, 0.0, -0.5, 0.0],"
              " [0.0] * 7, [0.0] * 4)"),
    Case("event_tol_one_second", "6", "error", field="event_tol_s",
         code="r = s.simulate(HOP, HOPB, q0h, t_final=0.01, event_tol_s=1.0)"),
    Case("observe_unknown_key", "6", "error", field="delay",
         code="r = motor.observe(dict(P, delay=0.01), 1e-3, *LOG)"),
    Case("thermal_ambient_minus_300", "6", "error", field="ambient_c",
         code="r = motor.thermal_simulation('x-rhex-28', [1.0], ambient_c=-300.0)"),
    Case("rank_tail_motors_max_length_nan", "6", "error", field="max_length_m",
         code="r = motor.rank_tail_motors(1.57, 0.05, 1.29, max_length_m=float('nan'))"),
    Case("thermal_simulation_empty_profile", "6", "error", field="torque_n_m",
         code="r = motor.thermal_simulation('x-rhex-28', [])"),
    Case("leap_param_given_twice", "6", "error", field="m_b", code="r = s.leap(params={'m_b': 5}, m_b=9)"),
    Case("cli_leap_mcap_empty", "6", "error", field="--mcap", argv=["leap", "--mcap", ""]),
    Case("cli_simulate_plot_empty", "6", "error", field="--plot",
         argv=[*HOP_CLI, "--t-final=0.01", "--plot", ""]),
    Case("cli_plot_out_empty", "6", "error", field="--out", setup="open('t.csv', 'w').write('x\\n1\\n')",
         argv=["plot", "t.csv", "--out", ""], check="files == []"),
    Case("cli_sweep_out_empty", "6", "error", field="--out", argv=["sweep", "--t2=0", "--out", ""]),
    Case("cli_strategy_empty_item", "6", "error", field="--strategy", argv=["sweep", "--strategy=++,,", "--t2=0"]),
    Case("cli_analysis_fig4_8_n_0", "6", "error", field="n", argv=["analysis", "fig4.8", "--n=0"]),
    Case("cli_chapter3_out_dir_missing_parents", "6", "error", field="out",
         argv=["chapter3", "--out-dir", "no/such/dir", "--n=1"], check="files == []"),
    # 7. generic errors
    Case("contact_mode_map_1e20", "7", "error", field="n", code="r = s.rhex.Model().contact_mode_map(10**20)"),
    Case("jacobian_part_1e20", "7", "error", field="part",
         code="m = s.Robot.from_file(QUAD); r = m.jacobian([0.0] * m.nq, 10**20)"),
    Case("rank_tail_motors_seed_1e30", "7", "error", field="seed",
         code="r = motor.rank_tail_motors(1.57, 0.05, 1.29, seed=10**30)"),
    Case("sweep_progress_yes", "7", "error", field="progress", code="r = s.sweep('++', t2=0.0, progress='yes')"),
    Case("any_robot_sweep_progress_yes", "7", "error", field="progress",
         code="r = s.sweep(HOP, HOPB, over={'kp_push': [30.0]}, q0=q0h, t_final=0.01, progress='yes')"),
    Case("sweep_config_list", "7", "error", field="config", code="r = s.sweep('++', t2=0.0, config=[1])"),
    Case("torque_speed_curve_catalog_toml_5", "7", "error", field="catalog_toml",
         code="r = motor.torque_speed_curve('x-rhex-28', catalog_toml=5)"),
    Case("simulate_params_list", "7", "error", field="params",
         code="r = s.simulate(HOP, HOPB, q0h, t_final=0.01, params=[1])"),
    Case("binary_description_file", "7", "error", field="path",
         code="import tempfile\np = tempfile.mkdtemp() + '/r.toml'\nopen(p, 'wb').write(b'\\xff\\xfe\\x00name = 1\\x80')\n"
              "r = s.Robot.from_file(p)"),
    Case("from_json_lone_surrogate", "7", "error", field="text", code="r = s.Robot.from_json('\\ud800')"),
    Case("initial_contacts_foot_foot", "7", "error", field="contacts",
         code="r = s.simulate(HOP, HOPB, q0h, contacts='foot,foot', t_final=0.01)"),
    Case("cli_leap_set_gear_ratio", "7", "error", field="gear_ratio", argv=["leap", "--set", "gear_ratio=28"]),
    Case("empty_behaviour_file", "7", "error", field="empty.toml",
         code="import tempfile\np = tempfile.mkdtemp() + '/empty.toml'\nopen(p, 'w').close()\n"
              "r = s.simulate(HOP, p, q0h, t_final=0.01)"),
    Case("zero_mass_link_with_inertia", "7", "error", field="legs[0].links[0]",
         code="r = s.simulate(one_leg([{'length_m': 0.0, 'mass_kg': 0.3, 'inertia_kg_m2': 0.0}]), None,"
              " [0.3, 0.0, -0.5, 0.0], t_final=0.05)"),
    Case("massless_link_between_massive_ones", "7", "error", field="legs[0].links",
         code="r = s.simulate(one_leg([{'length_m': 0.0, 'mass_kg': 0.0, 'inertia_kg_m2': 0.0},"
              " {'length_m': 0.2, 'mass_kg': 0.3, 'inertia_kg_m2': 0.002}]), None, [0.3, 0.3, 0.0, -0.5, 0.0],"
              " t_final=0.05)"),
    # 8. the CLI
    Case("cli_sweep_over_kp_push_1e12_values", "8", "error", field="--over",
         argv=["sweep", "--robot", f"{DATA}/hopper.toml", "--behaviour", f"{DATA}/hop.toml",
               "--q0=0.5,-1,0,-0.451,0", "--over", "kp_push=35:55:1e12"]),
    Case("cli_sweep_t2_1e11_values", "8", "error", field="--t2", argv=["sweep", "--t2=0:1:1e11"]),
    Case("cli_motor_duration_1e12", "8", "error", field="--duration", argv=["motor", "--duration=1e12"]),
    Case("cli_motor_duration_1e7_dt_1e-3", "8", "error", field="--duration",
         argv=["motor", "--duration=1e7", "--dt=1e-3"]),
    Case("cli_sweep_out_missing_directory_names_the_target", "8", "error", field="no/t.csv",
         argv=["sweep", "--t2=0", "--out", "no/t.csv"], check="'.tmp' not in err"),
    Case("rtol_1e308_message_is_short", "8", "error", field="rtol",
         code="r = s.simulate(HOP, HOPB, q0h, t_final=0.01, rtol=1e308)", check="len(str(err)) < 300"),
]

# Writers stopped by a signal: the final name holds a complete file or nothing, no temporary
# file is left visible beside it, and the next run removes what a killed one left.
WRITER = {
    "csv": "import selfmanip as s, numpy as np\n"
           "from selfmanip._tables import write_table\n"
           "t = {'x': np.arange(1_000_000.0), 'y': np.arange(1_000_000.0)}\n"
           "write_table(t, sys.argv[1])\n",
    "mcap": "import selfmanip as s\n"
            "e = s.simulate(HOP, HOPB, q0h, t_final=1.0)\n"
            "e.to_mcap(sys.argv[1], dt=2.5e-5)\n",
}


def killed_writer(kind: str, sig: str) -> Case:
    """Starts a writer of a big ``kind`` file, sends it ``sig`` once its temporary file exists,
    then runs the write again: ``r`` records what was left after each."""
    name = "big." + kind
    code = f"""
import tempfile
d = tempfile.mkdtemp()
target = os.path.join(d, {name!r})
script = os.path.join(d, 'w.py')
open(script, 'w').write({PRELUDE!r} + {WRITER[kind]!r})
p = subprocess.Popen([sys.executable, script, target])
started = False
for _ in range(24000):
    if any(f.endswith('.tmp') for f in os.listdir(d)):
        started = True
        break
    if p.poll() is not None:
        break
    time.sleep(0.005)
p.send_signal(signal.{sig})
p.wait()
after_kill = sorted(f for f in os.listdir(d) if f != 'w.py')
final_complete = None
if {name!r} in after_kill:
    final_complete = os.path.getsize(target) > 0
q = subprocess.run([sys.executable, script, target])
after_rerun = sorted(f for f in os.listdir(d) if f != 'w.py')
r = dict(started=started, after_kill=after_kill, rerun_rc=q.returncode, after_rerun=after_rerun,
         final_complete=final_complete)
"""
    check = (f"r['started'] and all(f.startswith('.') for f in r['after_kill'] if f != {name!r}) and "
             f"r['final_complete'] in (None, True) and r['rerun_rc'] == 0 and r['after_rerun'] == [{name!r}]")
    return Case(f"{sig.lower()}_during_a_{kind}_write", "8", "result", code=code, check=check, timeout_scale=4.0)


CASES += [killed_writer("csv", "SIGINT"), killed_writer("csv", "SIGKILL"),
          killed_writer("mcap", "SIGINT"), killed_writer("mcap", "SIGKILL")]


CHILD = """
import json, math, sys, traceback
MARK = {mark!r}
def finite(x, depth=0):
    import numpy as np
    if depth > 6:
        return True
    if isinstance(x, bool) or x is None or isinstance(x, str):
        return True
    if isinstance(x, (int, float, np.floating, np.integer)):
        return math.isfinite(float(x))
    if isinstance(x, np.ndarray):
        return x.dtype.kind not in "fc" or bool(np.all(np.isfinite(x)))
    if isinstance(x, dict) and "error" in x and "status" in x:
        # a sweep table: the rows that ran hold finite numbers; a failed row's typed status
        # and error say why its numbers are NaN
        ran = np.asarray([e == "" for e in x["error"]])
        return all(finite(np.asarray(v)[ran], depth + 1) for v in x.values())
    if isinstance(x, dict):
        return all(finite(v, depth + 1) for v in x.values())
    if isinstance(x, (list, tuple)):
        return all(finite(v, depth + 1) for v in x)
    if hasattr(x, "q_names") and hasattr(x, "contact_points_m"):
        # a trajectory: an inactive contact's point and force are NaN by definition
        return all(finite(getattr(x, k), depth + 1) for k in ("t_s", "q", "qd", "tau"))
    if hasattr(x, "__dict__"):
        return all(finite(v, depth + 1) for k, v in vars(x).items() if not k.startswith("_"))
    for name in ("q_end", "qd_end", "t_end_s"):
        if hasattr(x, name) and not finite(getattr(x, name), depth + 1):
            return False
    return True
def checked(ns):
    # the case's check over its outcome: None without one, False when it fails or raises
    if not {check!r}:
        return None
    try:
        return bool(eval({check!r}, ns))
    except Exception:
        return False
def report(**kw):
    print(MARK + json.dumps(kw, default=str), flush=True)
ns = {{}}
try:
    exec(compile({prelude!r}, "<prelude>", "exec"), ns)
    exec(compile({code!r}, "<case>", "exec"), ns)
except MemoryError:
    report(kind="memory")
except BaseException as err:
    from selfmanip.errors import SelfmanipError
    ns["err"] = err
    ok = checked(ns)
    report(kind="typed" if isinstance(err, SelfmanipError) else "generic", cls=type(err).__name__,
           field=getattr(err, "field", None) or "", message=str(err)[:300], check=ok)
else:
    r = ns.get("r")
    ok = checked(ns)
    report(kind="result", finite=finite(r), check=ok, summary=repr(r)[:200])
"""


def limits(memory_gb: float):
    def apply() -> None:
        cap = int(memory_gb * 2**30)
        resource.setrlimit(resource.RLIMIT_AS, (cap, cap))
        # a shell's background job ignores SIGINT, and so would its children (Python then
        # installs no KeyboardInterrupt handler): the cases that send it need the default
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        os.setsid()
    return apply


def classify_python(case: Case, proc_rc: int | None, out: str) -> tuple[str, str]:
    line = next((l for l in out.splitlines() if l.startswith(MARK)), None)
    if line is None:
        return ("crash", f"signal {-proc_rc}") if proc_rc is not None and proc_rc < 0 else \
            ("crash", f"no report, rc {proc_rc}")
    rep = json.loads(line[len(MARK):])
    if rep["kind"] == "memory":
        return "out-of-memory", "MemoryError"
    if rep["kind"] == "generic":
        return "generic-error", f"{rep['cls']}: {rep['message'][:120]}"
    if rep["kind"] == "typed":
        detail = f"{rep['cls']}[{rep['field']}]: {rep['message'][:100]}"
        if case.want == "error":
            if not rep["field"] or case.field not in rep["field"] and case.field not in rep["message"]:
                return "untyped-field", detail
            if rep["check"] is False:
                return "wrong-answer", detail
            return "typed-error", detail
        if case.want == "either" and rep["field"] and case.field in rep["field"]:
            return "typed-error", detail
        return "unexpected-typed-error", detail
    detail = rep["summary"][:120]
    if not rep["finite"]:
        return "non-finite", detail
    if case.want == "error":
        return "silently-accepted", detail
    if rep["check"] is False:
        return "wrong-answer", detail
    return ("typed-status" if case.want == "status" else "finite-result"), detail


def classify_cli(case: Case, rc: int, out: str, err: str, files: list[str]) -> tuple[str, str]:
    if rc < 0:
        return "crash", f"signal {-rc}"
    if "Traceback (most recent call last)" in err:
        return "traceback", err.strip().splitlines()[-1][:120]
    ns = {"out": out, "err": err, "files": files}
    ok = eval(case.check, ns) if case.check else True
    if rc == 0:
        return ("silently-accepted" if case.want == "error" else "finite-result"), out.strip()[:120]
    if rc == 2:
        if case.field and case.field not in err:
            return "untyped-field", err.strip()[:120]
        return ("typed-error" if ok else "wrong-answer"), err.strip().splitlines()[-1][:120] if err.strip() else ""
    return "generic-error", f"rc {rc}: {err.strip()[-120:]}"


WANTED = {"error": {"typed-error"}, "result": {"finite-result"}, "status": {"typed-status"},
          "either": {"typed-error", "finite-result"}}


def run(case: Case, timeout: float, memory_gb: float) -> tuple[str, str, float]:
    t0 = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="audit31-") as work:
        if case.argv:
            if case.setup:
                subprocess.run([sys.executable, "-c", case.setup], cwd=work, check=True)
            before = set(os.listdir(work))
            cmd = [sys.executable, "-m", "selfmanip", *case.argv]
        else:
            child = CHILD.format(mark=MARK, prelude=PRELUDE, code=textwrap.dedent(case.code), check=case.check)
            cmd = [sys.executable, "-c", child]
        p = subprocess.Popen(cmd, cwd=work, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                             preexec_fn=limits(memory_gb))
        try:
            out, err = p.communicate(timeout=timeout * case.timeout_scale)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, 9)
            p.communicate()
            return "hang", f"> {timeout * case.timeout_scale:g} s", time.monotonic() - t0
        if case.argv:
            files = sorted(set(os.listdir(work)) - before)   # what the run wrote
            cls, detail = classify_cli(case, p.returncode, out, err, files)
        else:
            cls, detail = classify_python(case, p.returncode, out)
            if cls == "crash" and "MemoryError" in err:
                cls = "out-of-memory"
            if cls == "crash" and err.strip():
                detail += " | " + err.strip().splitlines()[-1][:100]
    return cls, detail, time.monotonic() - t0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--timeout", type=float, default=60.0, help="wall-clock limit per case (s)")
    ap.add_argument("--memory-gb", type=float, default=4.0, help="address-space limit per case (GiB)")
    ap.add_argument("--only", default="", help="run the cases whose name holds one of these (comma-separated)")
    ap.add_argument("--json", default="", help="write the outcomes as JSON lines here")
    args = ap.parse_args()
    rows = []
    for case in CASES:
        if not any(part in case.name for part in args.only.split(",")):
            continue
        cls, detail, secs = run(case, args.timeout, args.memory_gb)
        ok = cls in WANTED[case.want]
        rows.append(dict(name=case.name, item=case.item, want=case.want, outcome=cls, ok=ok, detail=detail,
                         seconds=round(secs, 2)))
        print(f"{'ok  ' if ok else 'FAIL'} {case.item} {case.name:55} {cls:18} {secs:6.1f}s  {detail}", flush=True)
    counts: dict[str, int] = {}
    for row in rows:
        counts[row["outcome"]] = counts.get(row["outcome"], 0) + 1
    bad = [r for r in rows if not r["ok"]]
    print(f"\n{len(rows)} cases: " + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())))
    print(f"{len(rows) - len(bad)} pass, {len(bad)} fail" + ("".join(f"\n  {r['name']}: {r['outcome']}" for r in bad)))
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            for row in rows:
                f.write(json.dumps(row) + "\n")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
