"""Regression tests for the traps of issues 16 and 17 that a user met on the Python side, one
test per trap, named after it."""

import contextlib
import io
import json
import math
import os
import pickle
import signal
import subprocess
import sys
import textwrap
import threading
import types
import warnings

import numpy as np
import pytest

import selfmanip
from selfmanip import cli
from selfmanip.cli_leap import _sets
from conftest import QUADRUPED, REPO

Q = [0.3, 0.3, 0.0, -0.17 * math.cos(0.3), 0.0]


def run_cli(argv):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = cli.main(argv)
    return code, out.getvalue(), err.getvalue()


# ------------------------------------------------------------------ defaults and actuators


def test_leap_without_gear_ratio_runs_the_engines_default_actuator():
    """The binding chooses no actuator of its own: a leap without ``gear_ratio`` runs
    ``LeapConfig::default()``'s, and reports it."""
    default = selfmanip.leap.defaults()["config"]["actuator"]
    r = selfmanip.leap("++", 0.01, dt=None)
    assert r.config["actuator"] == default
    if default["kind"] == "geared_motor":
        assert r.gear_ratio == default["gear_ratio"]
        explicit = selfmanip.leap("++", 0.01, default["gear_ratio"], dt=None)
        assert (explicit.status, explicit.word, explicit.apex, explicit.events) == (r.status, r.word, r.apex,
                                                                                     r.events)
    else:
        assert r.gear_ratio is None
    # the sweep's default is the same
    t = selfmanip.sweep("++", t2=[0.01])
    assert (t["status"][0], t["word"][0]) == (r.status, r.word)


def test_saturated_torque_with_a_current_limit_is_refused_not_misreported():
    """``leap(gear_ratio=None, current_limit_a=20)`` used to run the geared motor and report the
    saturated torque: the combination is a contradiction and names the field."""
    with pytest.raises(selfmanip.InvalidInputError, match="current_limit_a.*saturated") as e:
        selfmanip.leap("++", 0.01, None, dt=None, current_limit_a=20.0)
    assert e.value.field == "current_limit_a"
    with pytest.raises(selfmanip.InvalidInputError, match="motors_per_leg"):
        selfmanip.sweep("++", t2=[0.0], gear_ratio=[None, 28.0], motors_per_leg=[1, 2])
    # what a leap reports is what it ran: read from the configuration it used
    sat = selfmanip.leap("++", 0.01, None, dt=None)
    assert sat.gear_ratio is None and sat.config["actuator"] == {"kind": "saturated_torque"}
    geared = selfmanip.leap("++", 0.01, 20.0, dt=None, current_limit_a=9.0)
    assert geared.gear_ratio == 20.0
    assert geared.config["actuator"]["gear_ratio"] == 20.0 and geared.config["actuator"]["current_limit_a"] == 9.0


def test_parameters_a_default_leaves_unset_are_not_taken_for_the_geared_motors_fields():
    """``mu_body``, ``leg_rotors`` and ``leg_armature_kg_m2`` (parameters the defaults leave
    unset, so absent from their serialization) were refused with ``gear_ratio=None`` as if they
    set the geared motor. The names that do are the engine's own list."""
    assert set(selfmanip.leap._actuator_fields()) == {
        "current_limit_a", "motors_per_leg", "gearbox_efficiency", "gearbox_loss", "battery_resistance_ohm"}
    # body-end friction with the saturated torque; μ = 0 is the frictionless default (its
    # limit: it raised SingularKktError, the start's two sticking ends being indeterminate)
    base = selfmanip.leap("++", 0.01, None, dt=None)
    mu0 = selfmanip.leap("++", 0.01, None, dt=None, mu_body=0.0)
    assert (mu0.word, mu0.apex.z_m, mu0.apex.phi_rad) == (base.word, base.apex.z_m, base.apex.phi_rad)
    near = selfmanip.leap("++", 0.01, None, dt=None, mu_body=1e-9)
    assert near.word == base.word
    assert near.apex.z_m == pytest.approx(base.apex.z_m, abs=1e-6)
    # the rotors with the saturated torque are X-RHex's at 28:1 (Table 2.1: J = tau_m k^2 / R,
    # two motors per planar leg): the same leap as that armature set by hand
    tau_m, k, r = 0.0118, 0.670 / 20.0, 37.0 / 20.0
    rot = selfmanip.leap("--", -0.02, None, dt=None, leg_rotors=True)
    hand = selfmanip.leap("--", -0.02, None, dt=None, leg_armature_kg_m2=2 * tau_m * k * k / r * 28.0**2)
    assert rot.word == hand.word
    assert rot.apex.z_m == pytest.approx(hand.apex.z_m, rel=1e-6, abs=0.0)
    assert rot.word != selfmanip.leap("--", -0.02, None, dt=None).word


# ------------------------------------------------------------------------- FFI hygiene


def test_structured_values_cross_as_python_objects_not_json_text():
    native = selfmanip._native
    assert not [n for n in dir(native) if "json" in n.lower()]
    r = selfmanip.leap("++", 0.0, dt=0.01)
    assert isinstance(r.params, dict) and isinstance(r.config, dict) and isinstance(r.config["terrain"], dict)
    assert isinstance(r.events, list) and all(isinstance(e, dict) for e in r.events)
    assert isinstance(selfmanip.analysis.sensor_pitch_range(grid=8), dict)
    # a terrain given as a dict reaches the engine as a dict (no text in between)
    ledge = {"kind": "ledge", "height_m": 0.2, "distance_m": 0.6}
    assert selfmanip.leap("++", 0.0, dt=None, terrain=ledge).config["terrain"] == ledge


def test_errors_map_by_variant_and_name_the_field(rhex):
    with pytest.raises(selfmanip.InvalidInputError) as e:
        selfmanip.rhex.Model({"m_b": -1.0})
    assert e.value.field == "m_b"
    with pytest.raises(selfmanip.InvalidInputError) as e:
        rhex.dynamics("0101", Q[:4], [0.0] * 5, [0.0, 0.0])
    assert e.value.field == "q"
    with pytest.raises(selfmanip.InvalidInputError) as e:
        selfmanip.leap("++", dt=None, terrain={"kind": "ledge", "height_m": -0.2, "distance_m": 0.6})
    assert e.value.field == "terrain.height_m"
    with pytest.raises(selfmanip.InvalidTypeError) as e:
        selfmanip.leap("++", dt=None, params={"m_b": "heavy"})
    assert e.value.field == "m_b"
    with pytest.raises(selfmanip.SingularKktError) as e:
        rhex.dynamics("1111", Q, [0.0] * 5, [0.0, 0.0])
    assert e.value.kind == "RedundantConstraints" and e.value.condition_estimate > 1e6


def test_errors_survive_pickling_for_dask():
    try:
        selfmanip.leap("++", dt=None, params={"rho2": 0.0})
    except selfmanip.InvalidInputError as e:
        back = pickle.loads(pickle.dumps(e))
        assert type(back) is selfmanip.InvalidInputError and back.field == e.field == "rho2"
        assert str(back) == str(e)
    else:
        pytest.fail("no error")


def test_quasi_static_in_flight_is_ill_posed_not_an_internal_error(rhex, quadruped):
    """``quasi_static("0000", q)`` raised a bare RuntimeError ("internal error", a panic)."""
    for robot, mode, q in ((rhex, "0000", Q), (rhex, "0100", Q), (quadruped, "", [0.0] * 7)):
        with pytest.raises(selfmanip.IllPosedError, match="contact"):
            robot.quasi_static(mode, q)
    # a body and a massive two-link arm, no contact
    no_contacts = selfmanip.Robot.from_file(REPO / "tests" / "data" / "robots" / "two_link_arm.toml")
    with pytest.raises(selfmanip.IllPosedError):
        no_contacts.quasi_static("", [0.0] * 5)


def test_a_relative_tolerance_of_one_or_more_is_refused_naming_rtol():
    """``leap(..., rtol=1000)`` ended in a ``SingularKktError`` (the steps' error as large as the
    state drove a leg through the ground); ``simulate`` took it too. A relative tolerance lies
    in (0, 1)."""
    for rtol in (1.0, 1000.0):
        with pytest.raises(selfmanip.InvalidInputError, match="rtol") as e:
            selfmanip.leap("++", -0.11, None, dt=None, rtol=rtol)
        assert e.value.field == "rtol"
        with pytest.raises(selfmanip.InvalidInputError, match="rtol"):
            selfmanip.simulate(QUADRUPED.parent / "rocking_block.toml", None, [0.0, -0.1, 0.3], t_final=0.1, rtol=rtol)
    assert selfmanip.leap("++", -0.11, None, dt=None, rtol=1e-6).status == "apex"


def test_a_run_cut_by_its_step_budget_carries_no_tangent():
    """``simulate(..., sensitivity=True)`` with steps bounded at 35 µs ran to its step budget and
    then carried the tangent over those 20,000 steps: two seconds for a run of a fifth of one
    (found by fuzzing). Such a run ends where its work ran out, not at a time of the model: its
    events say so and there is no state Jacobian; a run that ends at its final time keeps them."""
    data = REPO / "crates" / "selfmanip-sim" / "examples" / "data"
    q0 = [0.5, -1.0, 0.0, -(0.1 + 0.4 * math.cos(0.5)), 0.0]
    cut = selfmanip.simulate(data / "hopper.toml", data / "hop.toml", q0, t_final=3.0, h_max_s=3.5e-5,
                             sensitivity=True)
    assert cut.status == "step_budget" and cut.events and cut.state_jacobian is None
    for ev in cut.events:
        assert ev["saltation_status"] == "unsupported" and "step budget" in ev["saltation_reason"]
        assert ev["saltation"] is None and ev["time_gradient"] is None
    whole = selfmanip.simulate(data / "hopper.toml", data / "hop.toml", q0, t_final=0.5, sensitivity=True)
    assert whole.status == "final_time"
    assert any(ev["saltation_status"] == "defined" for ev in whole.events)
    # the run says why it ended, in words with its budget and instant (a complete one: nothing)
    assert "step budget (max_steps: 20000 accepted steps)" in cut.reason, cut.reason
    assert f"t = {cut.outcome['t_end_s']:.6f} s" in cut.reason and "{" not in cut.reason, cut.reason
    assert whole.reason == ""


def test_sensitivities_not_covered_on_a_terrain_corner_keep_the_run():
    """``simulate(..., sensitivity=True)`` of a hopper whose foot rolls over a stair's edge raised
    ``EngineError`` ("its turning frame is not differentiated") and lost the run (found by
    fuzzing). The run comes back as without sensitivities, each event saying why it has none."""
    data = REPO / "crates" / "selfmanip-sim" / "examples" / "data"
    args = (data / "hopper.toml", data / "hop_up.toml", [0.5, -1.0, 0.0, -0.5555, -0.0708])
    stairs = {"kind": "stairs", "rise_m": 0.0468, "run_m": 0.0842, "count": 2, "distance_m": 0.0086}
    with_s = selfmanip.simulate(*args, terrain=stairs, t_final=1.0, sensitivity=True)
    without = selfmanip.simulate(*args, terrain=stairs, t_final=1.0)
    assert with_s.word == without.word and len(with_s.events) == len(without.events) > 0
    assert [e["t_s"] for e in with_s.events] == [e["t_s"] for e in without.events]
    assert with_s.state_jacobian is None
    for ev in with_s.events:
        assert ev["saltation_status"] == "unsupported" and "terrain corner" in ev["saltation_reason"]


def test_contact_mode_map_with_negative_n_is_a_value_error_naming_n(rhex):
    """``contact_mode_map(-1)`` raised ``OverflowError``."""
    for n in (-1, 0, 5000):
        with pytest.raises(selfmanip.InvalidInputError, match="`n`") as e:
            rhex.contact_mode_map(n)
        assert e.value.field == "n" and isinstance(e.value, ValueError)


def test_engine_made_nan_is_not_blamed_on_the_callers_qd():
    """A leap takes no ``qd`` from the caller: a finite but absurd body mass whose start state
    overflows the model is refused as that parameter's fault (`m_b`), naming what overflowed, not as
    "`qd` has a non-finite entry"."""
    with pytest.raises(selfmanip.InvalidInputError, match="start state.*`N̄` overflows") as e:
        selfmanip.leap("++", 0.0, dt=None, params={"m_b": 1e308})
    assert "has a non-finite entry" not in str(e.value) and e.value.field == "m_b"
    # the same extreme model: the dynamics would come out NaN; refused rather than returned
    m = selfmanip.rhex.Model({"m_b": 1e308})
    with pytest.raises(selfmanip.EngineError, match="non-finite"):
        m.dynamics("0101", Q, [0.0] * 5, [1.0, 1.0])
    # while a NaN the caller passes is the caller's, named
    with pytest.raises(selfmanip.InvalidInputError, match="`qd` has a non-finite entry") as e:
        selfmanip.rhex.Model().dynamics("0101", Q, [0.0, math.nan, 0.0, 0.0, 0.0], [1.0, 1.0])
    assert e.value.field == "qd"


# ------------------------------------------------------------------- failed sweeps, loudly


def test_a_sweep_whose_points_all_fail_says_so():
    """The saturated-torque chapter-3 sweep once failed 164 of 164 points with an empty
    ``error`` column and exit code 0. Here every point fails by construction: the execution
    ends long before any leg could launch the robot."""
    with pytest.warns(selfmanip.AllPointsFailedWarning, match="all 3 points of the sweep failed.*final_time"):
        t = selfmanip.sweep("++", t2=[0.0, 0.02, 0.04], t_final_s=0.05)
    assert (t["status"] == "final_time").all() and not t["flew"].any()
    assert all("before t_final_s = 0.05 s" in e for e in t["error"])
    # one point that works: no warning
    with warnings.catch_warnings():
        warnings.simplefilter("error", selfmanip.AllPointsFailedWarning)
        t = selfmanip.sweep("++", t2=[0.0, 0.01], t_final_s=[0.05, 1.0], grid=False)
    assert list(t["status"]) == ["final_time", "apex"] and list(t["flew"]) == [False, True]
    assert t["error"][1] == ""


def test_cli_sweep_whose_points_all_fail_exits_non_zero(tmp_path):
    code, _, err = run_cli(["sweep", "--strategy", "++", "--t2", "0,0.02", "--set", "t_final_s=0.05",
                            "--out", str(tmp_path / "s.csv")])
    assert code == 1 and "error: all 2 points of the sweep failed" in err and "no flight" in err
    code, _, _ = run_cli(["sweep", "--strategy", "++", "--t2", "0,0.02", "--out", str(tmp_path / "t.csv")])
    assert code == 0


# ----------------------------------------------------------------------------- Ctrl-C

INTERRUPT_SCRIPT = textwrap.dedent("""
    import os, signal, sys, threading, time
    import numpy as np
    import selfmanip
    what = sys.argv[1]
    done = []
    threading.Timer(0.4, lambda: os.kill(os.getpid(), signal.SIGINT)).start()
    t0 = time.perf_counter()
    try:
        if what == "sweep":
            n = 40000
            selfmanip.sweep("++", t2=np.linspace(-0.2, 0.2, n), threads=2, progress=done.append)
        else:
            selfmanip.leap("+-", t2=0.13, gear_ratio=55.0, dt=None)
        print("completed", flush=True)
    except KeyboardInterrupt:
        print("interrupted", max(done, default=0), flush=True)
    # the interpreter is usable afterwards (no stray exception surfaces later)
    r = selfmanip.leap("++", 0.0, dt=None)
    print("after", r.status, flush=True)
    os._exit(0)  # do not wait for the abandoned worker
""")


@pytest.mark.parametrize("what", ["sweep", "leap"])
def test_ctrl_c_interrupts_a_leap_and_a_sweep(what, tmp_path):
    """Ctrl-C during a leap or a sweep surfaced later as a RuntimeError about the NumPy
    capsule. Now the call raises KeyboardInterrupt (a sweep before it has run all its
    points) and the interpreter goes on."""
    script = tmp_path / "interrupt.py"
    script.write_text(INTERRUPT_SCRIPT)
    p = subprocess.run([sys.executable, str(script), what], capture_output=True, text=True, timeout=120)
    lines = p.stdout.split("\n")
    if what == "leap" and lines[0] == "completed":
        pytest.skip("this leap no longer stalls long enough to be interrupted")
    assert lines[0].startswith("interrupted"), (p.stdout, p.stderr)
    if what == "sweep":
        assert int(lines[0].split()[1]) < 40000
    assert lines[1].startswith("after ") and "Error" not in p.stderr, p.stderr


FORK_SCRIPT = textwrap.dedent("""
    import os, sys
    import selfmanip
    selfmanip.leap("++", 0.0, dt=None)  # the parent's worker thread exists now
    pid = os.fork()
    if pid == 0:
        r = selfmanip.leap("++", 0.0, dt=None)  # the child has no such thread: it starts its own
        print("child", r.status, flush=True)
        os._exit(0)
    os.waitpid(pid, 0)
    print("parent", selfmanip.leap("++", 0.0, dt=None).status, flush=True)
""")


@pytest.mark.skipif(not hasattr(os, "fork"), reason="no fork")
def test_a_forked_child_runs_leaps(tmp_path):
    """Leaps run on a reused worker thread; a forked child (multiprocessing, Dask) inherits
    the record of it but not the thread, and must not wait for it forever."""
    script = tmp_path / "fork.py"
    script.write_text(FORK_SCRIPT)
    p = subprocess.run([sys.executable, "-W", "ignore::DeprecationWarning", str(script)], capture_output=True,
                       text=True, timeout=120)
    assert sorted(p.stdout.split("\n")[:2]) == ["child apex", "parent apex"], (p.stdout, p.stderr)


# ------------------------------------------------------------------------------ the CLI


def test_strategy_starting_with_a_dash_needs_no_equals_sign():
    """``--strategy -+`` was rejected by argparse (it needed ``--strategy=-+``)."""
    code, out, err = run_cli(["leap", "--strategy", "-+", "--t2", "-0.05", "--gear-ratio", "28"])
    assert code == 0, err
    assert out.startswith("leap -+ t2=-0.05 s gear ratio 28")
    code, out, err = run_cli(["sweep", "--strategy", "--", "--t2", "-0.02:0.02:3", "--threads", "1"])
    assert code == 0, err
    assert out.splitlines()[1].startswith("--,-0.02,")
    assert cli.attach_dash_values(["leap", "--json", "--strategy", "-+"], cli.build_parser()) == [
        "leap", "--json", "--strategy=-+"]


def test_set_terrain_json_is_one_value_not_a_range():
    """``--set terrain={...}`` was split at its commas as a list of values."""
    ledge = {"kind": "ledge", "height_m": 0.2, "distance_m": 0.6}
    assert _sets([f"terrain={json.dumps(ledge)}"]) == {"terrain": [ledge]}
    assert _sets(['pairs=["middle", "rear"]']) == {"pairs": [["middle", "rear"]]}
    code, out, err = run_cli(["leap", "--strategy", "++", "--set", f"terrain={json.dumps(ledge)}", "--json",
                              "--dt", "0.05"])
    assert code == 0, err
    assert json.loads(out)["config"]["terrain"] == ledge
    code, _, err = run_cli(["leap", "--set", "terrain={kind: ledge"])
    assert code == 2 and "--set terrain" in err and "JSON" in err


def test_import_selfmanip_leap_gives_the_module():
    """``import selfmanip.leap`` returned the function."""
    import selfmanip.leap as mod

    assert isinstance(mod, types.ModuleType) and mod is sys.modules["selfmanip.leap"]
    from selfmanip.leap import sweep_points  # noqa: F401  (the module's names import)

    r = selfmanip.leap("++", 0.0, dt=None)  # and the attribute still runs a leap
    assert isinstance(r, selfmanip.LeapResult)
    import inspect

    assert list(inspect.signature(selfmanip.leap).parameters)[:3] == ["strategy", "t2", "gear_ratio"]


def test_sweepable_names_list_pairs_once():
    names = selfmanip.leap.sweepable_names()
    assert names.count("pairs") == 1 and len(names) == len(set(names))


def test_broken_pipe_is_not_printed_as_an_error():
    """``selfmanip map | head -1`` printed "error: [Errno 32] Broken pipe"."""
    p = subprocess.Popen([sys.executable, "-m", "selfmanip", "map", "--n", "300"], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE)
    first = p.stdout.readline()
    p.stdout.close()  # the reader goes away, as `head -1` does
    err = p.stderr.read().decode()
    code = p.wait(timeout=120)
    assert first.startswith(b"theta1_rad,")
    assert err == "" and code == cli.EXIT_BROKEN_PIPE


@pytest.mark.parametrize("suffix", [".json", ".csv", ".mcap", ".parquet"])
def test_empty_input_file_is_named_not_a_bare_parser_error(tmp_path, suffix):
    """``selfmanip plot empty.json`` reported "Expecting value: line 1 column 1 (char 0)"."""
    empty = tmp_path / f"empty{suffix}"
    empty.write_bytes(b"")
    code, _, err = run_cli(["plot", str(empty), "--out", str(tmp_path / "x.png")])
    assert code == 2 and f"{empty}: the file is empty" in err, err
    if suffix == ".json":
        bad = tmp_path / "bad.json"
        bad.write_text("{not json")
        code, _, err = run_cli(["plot", str(bad), "--out", str(tmp_path / "x.png")])
        assert code == 2 and "not a leap JSON file" in err and str(bad) in err


# ---------------------------------------------------------------- apex of non-stopping leaps


def test_python_passes_the_apex_of_a_non_stopping_leap_through(monkeypatch):
    """The engine reports the first apex also when a leap runs on (issue 16); the Python side
    keeps whatever apex the engine gives, whatever ``stop_at_apex`` is."""
    real = selfmanip._native.leap_run
    apex = {"t_s": 0.3, "x_m": 0.1, "z_m": 0.25, "phi_rad": 0.05, "xdot_m_s": 1.0, "zdot_m_s": 0.0,
            "phidot_rad_s": 0.0}

    def with_apex(*args, **kwargs):
        d = real(*args, **kwargs)
        d["apex"] = apex
        return d

    monkeypatch.setattr(selfmanip.leap._native, "leap_run", with_apex)
    r = selfmanip.leap("++", 0.0, dt=0.01, stop_at_apex=False, t_final_s=0.5)
    assert r.apex == selfmanip.leap.Apex(**apex) and r.to_dict()["apex"] == apex


def test_non_stopping_leap_that_flew_reports_its_apex():
    """``stop_at_apex=False`` gave ``apex=None`` after a flight."""
    r = selfmanip.leap("++", 0.0, dt=None, stop_at_apex=False, t_final_s=1.0)
    assert r.status == "final_time" and r.flew and any(c == "0000" for c in r.cells)
    assert r.apex is not None and r.apex.z_m > -r.q0[r.q_names.index("z")]


# ------------------------------------------------------------------------------ analysis


def test_analysis_functions_accept_a_robot(quadruped):
    """``selfmanip.analysis`` raised ``TypeError ... got Robot`` and ``tail_effect`` wanted a
    path. Now: any analysis takes an RHex model as a Robot, ``tail_effect`` any robot, and an
    RHex analysis given another robot says why it cannot run."""
    from conftest import QUADRUPED, REPO

    q0, joints = [0.4, -0.8, -0.3, 0.7, 0, 0, 0], [0, 2]
    by_robot = selfmanip.analysis.tail_effect(quadruped, q0, joints, period_s=0.5, dt_s=5e-4)
    by_path = selfmanip.analysis.tail_effect(QUADRUPED, q0, joints, period_s=0.5, dt_s=5e-4)
    assert by_robot == by_path
    heavy = selfmanip.rhex.Model({"m_b": 8.0})
    robot: selfmanip.Robot = heavy
    assert selfmanip.analysis.pitch_rate_gain(0.3, model=robot) == selfmanip.analysis.pitch_rate_gain(
        0.3, model={"m_b": 8.0})
    with pytest.raises(selfmanip.InvalidTypeError, match="rhex.Model") as e:
        selfmanip.analysis.max_sensor_pitch(quadruped)
    assert e.value.field == "model"
