"""``selfmanip simulate`` and ``selfmanip sweep --robot`` (issue 17): a robot that is not RHex
through the CLI. The CLI's numbers are checked against the Python API's (a second entry point
to the same run), its files read back (CSV, Parquet, MCAP with the ``mcap`` package, PNG), and
its exit codes and messages for bad behaviour files, all-failed sweeps, Ctrl-C and a broken
pipe."""

from __future__ import annotations

import json
import math
import os
import pathlib
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import selfmanip
from selfmanip.cli import main
from selfmanip.cli_leap import read_table

DATA = pathlib.Path(__file__).resolve().parents[2] / "crates" / "selfmanip-sim" / "examples" / "data"
HOPPER, HOP = str(DATA / "hopper.toml"), str(DATA / "hop.toml")
A = 0.5
Q0 = [A, -2 * A, 0.0, -(0.1 + 0.4 * math.cos(A) + 0.02), 0.0]
Q0_ARG = ",".join(repr(v) for v in Q0)


def test_simulate_prints_the_run_and_writes_mcap_and_plot(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    mcap, png = tmp_path / "h.mcap", tmp_path / "h.png"
    rc = main(["simulate", HOPPER, HOP, "--q0", Q0_ARG, "--t-final", "0.45", "--mcap", str(mcap), "--plot", str(png)])
    out = capsys.readouterr().out
    assert rc == 0
    e = selfmanip.simulate(HOPPER, HOP, Q0, t_final=0.45)
    assert f"word {e.word_string}" in out
    assert f"status {e.status}" in out
    assert sum(1 for line in out.splitlines() if line.strip().startswith("t=")) == len(e.events)
    assert png.read_bytes()[:4] == b"\x89PNG"
    from mcap.reader import make_reader

    with open(mcap, "rb") as f:
        meta = {m.name: dict(m.metadata) for m in make_reader(f).iter_metadata()}
    assert meta["selfmanip"]["word"] == e.word_string


def test_simulate_json_equals_the_python_api(capsys):
    rc = main(["simulate", HOPPER, HOP, "--q0", Q0_ARG, "--t-final", "0.45", "--json", "--set", "kp_push=50"])
    assert rc == 0
    got = json.loads(capsys.readouterr().out)
    e = selfmanip.simulate(HOPPER, HOP, Q0, t_final=0.45, params={"kp_push": 50.0})
    assert got["events"] == e.events
    assert got["outcome"]["word"] == e.word
    assert got["energy"]["joint_work_j"] == e.energy_report().joint_work_j


def test_simulate_terrain_and_no_behaviour(capsys):
    """`none`: no actuation, so the massless leg keeps its pose in free fall and the foot
    circle (radius r = 0.02 m, centre 0.12 m above z = 0 under the hip at x = 0) falls freely.
    On an incline of slope s through the origin the circle touches when its centre is
    r / cos s above the plane's point below it, i.e. after a fall 0.12 - r / cos s; on flat
    ground after 0.1. Both at t = sqrt(2 fall / g)."""
    s = 0.2
    rc = main(["simulate", HOPPER, "none", "--q0", Q0_ARG, "--t-final", "0.3", "--terrain", f"incline,slope_rad={s}",
               "--json"])
    got = json.loads(capsys.readouterr().out)
    e = selfmanip.simulate(HOPPER, None, Q0, t_final=0.3, terrain={"kind": "incline", "slope_rad": s})
    assert got["events"] == e.events
    assert rc == (0 if e.complete else 1)
    assert got["events"][0]["kind"] == "touchdown"
    assert got["events"][0]["t_s"] == pytest.approx(math.sqrt(2 * (0.12 - 0.02 / math.cos(s)) / 9.81), abs=1e-9)
    flat = selfmanip.simulate(HOPPER, None, Q0, t_final=0.3, terrain="flat")
    assert flat.events[0]["t_s"] == pytest.approx(math.sqrt(2 * 0.1 / 9.81), abs=1e-9)


@pytest.mark.parametrize("fmt", ["csv", "parquet"])
def test_sweep_robot_writes_the_table_of_the_python_sweep(tmp_path, fmt, capsys):
    if fmt == "parquet":
        pytest.importorskip("pyarrow")
    out = tmp_path / f"s.{fmt}"
    rc = main(["sweep", "--robot", HOPPER, "--behaviour", HOP, "--q0", Q0_ARG, "--t-final", "0.4",
               "--over", "kp_push=35:55:3", "--over", "t_compress=0.04,0.06", "--threads", "2", "--out", str(out)])
    assert rc == 0
    assert "6 points, 6 complete" in capsys.readouterr().err
    got = read_table(str(out))
    want = selfmanip.sweep(HOPPER, HOP, over={"kp_push": np.linspace(35, 55, 3), "t_compress": [0.04, 0.06]},
                           q0=Q0, t_final=0.4, threads=1)
    assert list(got) == list(want)
    for k in ("kp_push", "t_compress", "apex_z_m", "end_x", "t_end_s"):
        assert np.array_equal(np.asarray(got[k], dtype=float), want[k], equal_nan=True), k
    for k in ("status", "word"):
        assert [str(x) for x in got[k]] == want[k].tolist(), k


def test_sweep_robot_all_failed_exits_1_and_says_why(capsys):
    rc = main(["sweep", "--robot", HOPPER, "--behaviour", HOP, "--q0", Q0_ARG, "--over", "kp_spring=-1,-2",
               "--threads", "1"])
    err = capsys.readouterr().err
    assert rc == 1
    assert "all 2 points of the sweep failed (2 invalid_value)" in err
    assert "joints[1].phases[1].torque.kp_n_m_per_rad" in err


def test_sweep_robot_keeps_good_points(capsys):
    rc = main(["sweep", "--robot", HOPPER, "--behaviour", HOP, "--q0", Q0_ARG, "--t-final", "0.3",
               "--over", "kp_spring=60,-1", "--threads", "2"])
    cap = capsys.readouterr()
    assert rc == 0
    rows = cap.out.strip().splitlines()
    header = rows[0].split(",")
    status = [r.split(",")[header.index("status")] for r in rows[1:]]
    assert status == ["final_time", "invalid_value"]
    assert main(["sweep", "--robot", HOPPER, "--behaviour", HOP, "--q0", Q0_ARG, "--t-final", "0.3",
                 "--over", "kp_spring=60,-1", "--strict"]) == 1


BAD = {
    "unknown joint": ('[[joints]]\njoint = "arm[0]"\n[[joints.phases]]\nname = "a"\n', "joints[0].joint"),
    "negative gain": ('[[joints]]\njoint = "leg[1]"\n[[joints.phases]]\nname = "a"\n'
                      'torque = { kind = "servo", kp_n_m_per_rad = -3.0, kd_n_m_s_per_rad = 1.0 }\n',
                      "joints[0].phases[0].torque.kp_n_m_per_rad"),
    "NaN": ('[[joints]]\njoint = "leg[1]"\n[[joints.phases]]\nname = "a"\n'
            'torque = { kind = "servo", kp_n_m_per_rad = 3.0, kd_n_m_s_per_rad = nan }\n',
            "joints[0].phases[0].torque.kd_n_m_s_per_rad"),
    "unknown event": ('[[joints]]\njoint = "leg[1]"\n[[joints.phases]]\nname = "a"\n[[joints.phases]]\nname = "b"\n'
                      'start = { event = "takeoff" }\n', "joints[0].phases[1].start.event"),
    "cyclic phases": ('[parameters]\na = "b + 1"\nb = "2 * a"\n', "cyclic references"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_behaviour_files_exit_2_naming_the_field(case, tmp_path, capsys):
    text, needle = BAD[case]
    p = tmp_path / "bad.toml"
    p.write_text(text)
    rc = main(["simulate", HOPPER, str(p), "--q0", Q0_ARG])
    err = capsys.readouterr().err
    assert rc == 2
    assert err.startswith("selfmanip: error: ") and needle in err, err


def test_bad_cli_input_exits_2(tmp_path, capsys):
    assert main(["simulate", HOPPER, HOP, "--q0", "1,2"]) == 2
    assert "initial.q" in capsys.readouterr().err
    assert main(["simulate", HOPPER, str(tmp_path / "none.toml"), "--q0", Q0_ARG]) == 2
    assert "not found" in capsys.readouterr().err
    assert main(["sweep", "--robot", HOPPER, "--behaviour", HOP, "--q0", Q0_ARG, "--over", "no.such.name=1"]) == 2
    assert "no.such.name" in capsys.readouterr().err
    assert main(["sweep", "--behaviour", HOP]) == 2  # a robot's option without --robot
    assert "--robot" in capsys.readouterr().err
    assert main(["simulate", HOPPER, HOP, "--q0", Q0_ARG, "--terrain", "ledge,height_m=x"]) == 2


def _cli(*argv: str) -> list[str]:
    return [sys.executable, "-m", "selfmanip", *argv]


def test_sweep_robot_ctrl_c_exits_130():
    # a long sweep (many points on one thread), interrupted once it has started
    p = subprocess.Popen(_cli("sweep", "--robot", HOPPER, "--behaviour", HOP, "--q0", Q0_ARG, "--t-final", "2",
                              "--over", "kp_push=30:60:400", "--threads", "1", "--progress", "always"),
                         stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 60
    seen = ""
    while time.time() < deadline and "sweep [" not in seen:
        seen += p.stderr.read(1)
    os.kill(p.pid, signal.SIGINT)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 130, err
    assert "interrupted" in err


def test_sweep_robot_broken_pipe_is_quiet():
    p = subprocess.Popen(_cli("sweep", "--robot", HOPPER, "--behaviour", HOP, "--q0", Q0_ARG, "--t-final", "0.2",
                              "--over", "kp_push=30:60:300", "--threads", "2", "--progress", "never"),
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    p.stdout.readline()
    p.stdout.close()  # the reader goes away, as `head -1` does
    err = p.stderr.read().decode()
    p.wait(timeout=120)
    assert p.returncode == 141, err
    assert "Broken pipe" not in err and "Traceback" not in err


def test_the_documented_python_and_commands_run(tmp_path, monkeypatch, capsys):
    """docs/python-simulate.md runs as written (data paths made absolute, outputs in a scratch
    directory): the Python blocks run, every `selfmanip ...` line exits 0 with its files."""
    pytest.importorskip("matplotlib")
    import re
    import shlex

    doc = (pathlib.Path(__file__).resolve().parents[2] / "docs" / "python-simulate.md").read_text()
    doc = doc.replace("crates/selfmanip-sim/examples/data/", str(DATA) + "/")
    monkeypatch.chdir(tmp_path)
    # the parallel recipes run in test_parallel_recipes.py
    py = re.findall(r"```python\n(.*?)```", doc.split("## Parallel runs")[0], flags=re.S)
    assert len(py) == 2
    for b in py:
        exec(compile(b, "python-simulate.md", "exec"), {})
    assert (tmp_path / "hopper.mcap").stat().st_size > 0
    lines = [l for b in re.findall(r"```sh\n(.*?)```", doc, flags=re.S) for l in b.splitlines()
             if l.startswith("selfmanip ")]
    assert len(lines) == 4
    for line in lines:
        assert main(shlex.split(line)[1:]) == 0, line
    for f in ("hopper.png", "hop_sweep.csv", "hop_sweep.png"):
        assert (tmp_path / f).stat().st_size > 0, f
