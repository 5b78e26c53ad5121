"""The command line: the demo runs, `dynamics` prints what the API computes, `map` writes n^2
rows, and errors exit with status 2 and a message."""

import io
import math

import pytest

from selfmanip import cli


def test_demo_reports_result_c1(capsys):
    assert cli.main(["demo"]) == 0
    out = capsys.readouterr().out
    line = next(l for l in out.splitlines() if "Result C.1" in l)
    got, want = (float(s.split()[0]) for s in line.split("push ")[1].split(" vs 2 tau / l = "))
    assert got == pytest.approx(want, rel=1e-9)


def test_dynamics_command_matches_api(capsys, rhex):
    q = [0.2, 0.2, 0.0, -0.17 * math.cos(0.2), 0.0]
    assert cli.main(["dynamics", "--mode", "0101", "--q", ",".join(map(str, q)), "--tau", "1,2"]) == 0
    out = capsys.readouterr().out.splitlines()
    qdd = [float(v) for v in out[1].split()[1:]]
    want = rhex.dynamics("0101", q, [0.0] * 5, [1.0, 2.0]).qdd
    assert qdd == pytest.approx(list(want), rel=1e-8, abs=1e-12)


def test_map_command_writes_grid(tmp_path):
    path = tmp_path / "map.csv"
    assert cli.main(["map", "--n", "6", "--csv", str(path)]) == 0
    lines = path.read_text().splitlines()
    assert lines[0].startswith("theta1_rad") and len(lines) == 1 + 36


def test_bad_mode_exits_with_message(capsys):
    assert cli.main(["dynamics", "--mode", "2222"]) == 2
    assert "label" in capsys.readouterr().err


def test_chapter3_main_job_writes_the_sweep_and_its_figure(tmp_path, capsys):
    """The default command's job (README's first command): the four strategies over t2, as a
    CSV whose rows are the leaps `selfmanip.leap` computes one by one (a second route through
    the API), and a PNG figure."""
    import csv

    import selfmanip

    assert cli.main(["chapter3", "--out-dir", str(tmp_path), "--n", "3", "--threads", "2"]) == 0
    out = capsys.readouterr().out
    rows = list(csv.DictReader(open(tmp_path / "chapter3_sweep.csv")))
    assert sorted({r["strategy"] for r in rows}) == sorted(["++", "+-", "-+", "--"])
    assert len(rows) == 4 * 3
    assert (tmp_path / "chapter3_sweep.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    for r in rows:
        one = selfmanip.leap(r["strategy"], t2=float(r["t2_s"]))
        assert (r["status"], r["flew"], r["word"]) == (one.status, str(one.flew), one.word)
        if one.flew:
            assert float(r["apex_z_m"]) == pytest.approx(one.apex.z_m, rel=1e-12)
    for s in ("++", "+-", "-+", "--"):
        ok = sum(r["flew"] == "True" for r in rows if r["strategy"] == s)
        assert f"({s[0]}, {s[1]}): {ok}/3 leaps reach an apex" in out
