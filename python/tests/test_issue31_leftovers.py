"""The reproducers of issue 31 that were still wanting after its first fixes:
a write killed outright (SIGKILL) left its temporary file for good, a run that ends at its
final time right after an event was sampled in the mode before the event (the sampler and
the engine disagreed on the last sample: the Painlevé report of a slide that had ended), and
errors that named no field or printed 1e308 as 309 digits."""

from __future__ import annotations

import os
import pathlib
import signal
import subprocess
import sys

import numpy as np
import pytest

import selfmanip
from selfmanip import cli, motor
from selfmanip._tables import remove_stale_temp_files, write_table
from selfmanip.errors import InvalidInputError

DATA = pathlib.Path(__file__).resolve().parents[2] / "crates" / "selfmanip-sim" / "examples" / "data"
HOP, HOPB = DATA / "hopper.toml", DATA / "hop.toml"
Q0H = [0.5, -1.0, 0.0, -0.451, 0.0]


def ended_pid() -> int:
    """The id of a process that has ended (a child, waited for)."""
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


def test_a_temp_file_of_a_killed_table_write_is_removed_by_the_next_write_of_it(tmp_path):
    dead, live = ended_pid(), os.getppid()   # the parent runs while this test does
    for name in (f".t.csv.{dead}.tmp", f".t.csv.{live}.tmp", f".other.csv.{dead}.tmp"):
        (tmp_path / name).write_text("partial")
    write_table({"x": np.arange(3.0)}, str(tmp_path / "t.csv"))
    assert sorted(os.listdir(tmp_path)) == sorted([".other.csv.%d.tmp" % dead, f".t.csv.{live}.tmp", "t.csv"])
    remove_stale_temp_files(str(tmp_path), "other.csv")
    assert ".other.csv.%d.tmp" % dead not in os.listdir(tmp_path)


WRITERS = {
    "csv": "import sys, numpy as np\nfrom selfmanip._tables import write_table\n"
           "write_table({'x': np.arange(2e6), 'y': np.arange(2e6)}, sys.argv[1])\n",
    "mcap": "import sys, selfmanip\n"
            f"e = selfmanip.simulate({str(HOP)!r}, {str(HOPB)!r}, {Q0H!r}, t_final=1.0)\n"
            "e.to_mcap(sys.argv[1], dt=2.5e-5)\n",
}


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
@pytest.mark.parametrize("kind", ["csv", "mcap"])
def test_a_write_killed_midway_leaves_no_file_under_its_name_and_the_next_write_cleans_up(tmp_path, kind):
    # SIGKILL left temp files of up to 45 MB, for good
    target = tmp_path / f"big.{kind}"
    script = tmp_path / "write.py"
    script.write_text(WRITERS[kind])
    p = subprocess.Popen([sys.executable, str(script), str(target)])
    tmp_name = f".big.{kind}.{p.pid}.tmp"
    for _ in range(24000):  # up to two minutes in 5 ms waits: a bound, not a timing
        if (tmp_path / tmp_name).exists() or p.poll() is not None:
            break
        try:
            p.wait(timeout=0.005)
        except subprocess.TimeoutExpired:
            pass
    assert (tmp_path / tmp_name).exists(), "the write never started"
    p.send_signal(signal.SIGKILL)
    p.wait()
    # nothing under the final name; what is left is hidden and names its writer
    assert sorted(os.listdir(tmp_path)) == sorted(["write.py", tmp_name])
    assert subprocess.run([sys.executable, str(script), str(target)]).returncode == 0
    assert sorted(os.listdir(tmp_path)) == sorted(["write.py", f"big.{kind}"])


def test_a_run_ending_at_an_event_is_sampled_last_in_the_state_after_the_reset():
    # the sampler took the last sample from the segment before the event (the flight before
    # a touchdown here; a slide that had become inconsistent in the three-legged
    # robot, hence its Painlevé error), while the engine ended in the state after it
    first = selfmanip.simulate(HOP, HOPB, Q0H, t_final=0.6)
    touchdown = next(ev for ev in first.events if ev["kind"] == "touchdown")
    e = selfmanip.simulate(HOP, HOPB, Q0H, t_final=touchdown["t_s"])
    assert e.status == "final_time" and e.events[-1]["kind"] == "touchdown"
    assert e.segments[-1]["t0_s"] == e.segments[-1]["t1_s"] == e.t_end_s   # a mode of zero duration
    tr = e.trajectory(0.01)
    assert tr.t_s[-1] == e.t_end_s
    # the engine's own end state
    np.testing.assert_array_equal(tr.q[-1], e.q_end)
    np.testing.assert_array_equal(tr.qd[-1], e.qd_end)
    assert tr.mode[-1] == e.events[-1]["mode_after"] != e.events[-1]["mode_before"] == tr.mode[-2]
    # a second route to the state after the touchdown: the run that went on, sampled on a
    # grid through the touchdown's instant, where its stance segment starts
    on = first.trajectory(touchdown["t_s"])
    assert on.t_s[1] == touchdown["t_s"] and on.mode[1] == tr.mode[-1]
    np.testing.assert_allclose(tr.qd[-1], on.qd[1], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(tr.q[-1], on.q[1], rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("args, field", [
    (([1e308] * 7,), "q"),
    (([0.3, -0.6, 0.3, -0.6, 0.0, -0.5, 0.0], [1e308] * 7), "qd"),
])
def test_kinematics_that_overflow_name_the_configuration_or_the_velocity(args, field):
    # an EngineError naming nothing before
    robot = selfmanip.Robot.from_file(DATA / "quadruped.toml")
    with pytest.raises(InvalidInputError) as e:
        robot.forward_kinematics(*args)
    assert e.value.field == field
    if field == "q":
        with pytest.raises(InvalidInputError) as e:
            robot.contact_gaps(*args)
        assert e.value.field == "q"


def test_cli_terrain_with_an_unknown_key_names_the_option_and_the_key(capsys):
    argv = ["simulate", str(HOP), str(HOPB), "--q0=" + ",".join(map(str, Q0H)), "--t-final=0.01",
            "--terrain=flat,x=1"]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert "`--terrain`" in err and "unknown field `x`" in err


def test_a_huge_motor_parameter_is_printed_in_exponent_form():
    # `delay_s` = 1000…000 (309 digits) before
    with pytest.raises(InvalidInputError) as e:
        motor.observe({"k_m": 50.0, "a_m": 20.0, "k_p": 10.0, "k_d": 0.5, "k_g": -1.0, "theta_g_rad": 0.0,
                       "delay_s": 1e308}, 1e-3, *[np.zeros(200)] * 4)
    assert e.value.field == "delay_s"
    assert "= 1e308:" in str(e.value) and len(str(e.value)) < 200
    with pytest.raises(InvalidInputError, match="`ambient_c` = -300:"):
        motor.thermal_simulation("x-rhex-28", [1.0], ambient_c=-300.0)


def test_a_figure_is_written_atomically_in_the_format_its_suffix_names(tmp_path):
    # figures were saved straight under their final name: a run killed midway left half a PNG
    pytest.importorskip("matplotlib")
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from selfmanip.plots import save_figure

    fig = plt.figure()
    save_figure(fig, tmp_path / "a.png")
    save_figure(fig, str(tmp_path / "a.pdf"))
    plt.close(fig)
    assert (tmp_path / "a.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (tmp_path / "a.pdf").read_bytes()[:5] == b"%PDF-"

    class Interrupted:
        def savefig(self, tmp, **kw):
            with open(tmp, "wb") as f:
                f.write(b"\x89PNG half")
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        save_figure(Interrupted(), tmp_path / "b.png")
    assert sorted(os.listdir(tmp_path)) == ["a.pdf", "a.png"]
