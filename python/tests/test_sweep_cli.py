"""`selfmanip leap | sweep | grc | plot FILE`: exit codes, the output columns and values equal
to the API's own result, clear errors naming the option, and the console script itself."""

import json
import math
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

import selfmanip
from selfmanip import cli
from selfmanip.cli_leap import parse_range, read_table

SWEEP_ARGS = ["sweep", "--strategy", "++,--", "--t2=-0.1:0.1:5", "--gear-ratio", "20,28", "--threads", "2",
              "--progress", "never"]


@pytest.fixture(scope="module")
def api_table():
    return selfmanip.sweep(["++", "--"], t2=np.linspace(-0.1, 0.1, 5), gear_ratio=[20.0, 28.0], threads=1)


def same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    if a.dtype.kind == "f":
        return np.array_equal(a, b.astype(float), equal_nan=True)
    return [str(x) for x in a] == [str(x) for x in b]


def test_parse_range_forms():
    assert parse_range("-0.2:0.2:41", "--t2") == list(np.linspace(-0.2, 0.2, 41))
    assert parse_range("18,24,30", "g") == [18.0, 24.0, 30.0]
    assert parse_range("0.5", "g") == [0.5]
    for bad in ("0:1", "0:1:0", "0:1:2.5", "a:b:3", "", "0:1:1", "nan", "1,,x"):
        with pytest.raises(ValueError, match="--t2"):
            parse_range(bad, "--t2")


def test_sweep_csv_equals_the_api(tmp_path, api_table, capsys):
    out = tmp_path / "s.csv"
    assert cli.main(SWEEP_ARGS + ["--out", str(out)]) == 0
    assert "20 points" in capsys.readouterr().err
    got = read_table(str(out))
    assert list(got) == list(api_table)
    for k in api_table:
        assert same(api_table[k], got[k]), k
    pd = pytest.importorskip("pandas")
    df = pd.read_csv(out, keep_default_na=False, na_values=["nan"])
    assert list(df.columns) == list(api_table)
    assert np.array_equal(df["apex_z_m"].to_numpy(), api_table["apex_z_m"], equal_nan=True)


def test_sweep_parquet_equals_the_api(tmp_path, api_table):
    pytest.importorskip("pyarrow")
    out = tmp_path / "s.parquet"
    assert cli.main(SWEEP_ARGS + ["--out", str(out)]) == 0
    got = read_table(str(out))
    for k in api_table:
        assert same(api_table[k], got[k]), k


def test_sweep_to_stdout_and_swept_parameters(capsys):
    assert cli.main(["sweep", "--t2", "0", "--set", "m_b=8:10:2", "--set", "leg_shape=half_circle,stick",
                     "--progress", "never"]) == 0
    lines = capsys.readouterr().out.splitlines()
    header = lines[0].split(",")
    assert header[:5] == ["strategy", "t2_s", "gear_ratio", "m_b", "leg_shape"] and len(lines) == 5
    want = selfmanip.sweep("++", t2=0.0, gear_ratio=28.0, m_b=[8.0, 10.0], leg_shape=["half_circle", "stick"])
    rows = [l.split(",") for l in lines[1:]]
    assert [r[header.index("word")] for r in rows] == list(want["word"])
    assert [float(r[header.index("apex_z_m")]) for r in rows] == pytest.approx(list(want["apex_z_m"]),
                                                                                 nan_ok=True, rel=0, abs=0)


@pytest.mark.parametrize("argv, needle", [
    (["sweep", "--t2=0:1:x"], "--t2"),
    (["sweep", "--t2=0:1:0"], "--t2"),
    (["sweep", "--gear-ratio", "18:30"], "--gear-ratio"),
    (["sweep", "--gear-ratio", "-5"], "--gear-ratio"),
    (["sweep", "--strategy", "++,+x"], "strategy"),
    (["sweep", "--set", "no_such=1"], "no_such"),
    (["sweep", "--set", "m_b"], "--set"),
    (["sweep", "--out", "table.txt"], "--out"),
    (["sweep", "--threads", "0"], "--threads"),
    (["leap", "--strategy", "x"], "strategy"),
    (["leap", "--t2=0:1:3"], "--t2"),
    (["leap", "--set", "leg_shape=triangle"], "leg_shape"),
    (["plot", "missing.csv", "--out", "x.png"], "missing.csv"),
])
def test_bad_input_exits_2_with_a_message(argv, needle, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("selfmanip: error:") and needle in err
    assert not list(tmp_path.iterdir()), "a failed command leaves no file"


def test_strict_sweep_exits_1_when_a_point_fails(capsys):
    argv = ["sweep", "--t2", "0", "--set", "m_b=9,-1", "--progress", "never", "--strict"]
    assert cli.main(argv) == 1
    assert "invalid_params" in capsys.readouterr().err
    assert cli.main(argv[:-1]) == 0


def test_leap_json_equals_the_api(capsys):
    assert cli.main(["leap", "--strategy=-+", "--t2=-0.05", "--gear-ratio", "25", "--json"]) == 0
    got = json.loads(capsys.readouterr().out)
    want = selfmanip.leap("-+", t2=-0.05, gear_ratio=25.0).to_dict()
    assert got == want


def test_leap_text_and_mcap(tmp_path, capsys):
    path = tmp_path / "leap.mcap"
    assert cli.main(["leap", "--mcap", str(path)]) == 0
    out = capsys.readouterr().out
    r = selfmanip.leap("++", 0.0, 28.0, dt=None)
    assert f"status {r.status}" in out and f"word {r.word}" in out
    assert path.read_bytes()[:8] == b"\x89MCAP0\r\n"


def test_grc_prints_the_complex_and_the_grammar(capsys):
    assert cli.main(["grc"]) == 0
    out = capsys.readouterr().out
    g = selfmanip.rhex.ground_reaction_complex()
    for c in g["cells"]:
        assert f"\n{c['label']} " in out
    for w in g["leap_words"]:
        assert f"({w['equation']})" in out
    assert f"Allowable transitions (Fig. 3.3): {len(g['allowable'])}" in out
    assert cli.main(["grc", "--json"]) == 0
    assert json.loads(capsys.readouterr().out) == g


def test_plot_from_a_sweep_file_and_a_leap(tmp_path):
    pytest.importorskip("matplotlib")
    table = tmp_path / "s.csv"
    assert cli.main(SWEEP_ARGS + ["--out", str(table)]) == 0
    png = tmp_path / "s.png"
    assert cli.main(["plot", str(table), "--out", str(png)]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    leap_json = tmp_path / "l.json"
    r = selfmanip.leap("++", 0.0, 28.0)
    leap_json.write_text(json.dumps(r.to_dict()))
    for src in (leap_json,):
        out = tmp_path / f"{src.stem}.png"
        assert cli.main(["plot", str(src), "--out", str(out)]) == 0
        assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_console_script_exit_codes(tmp_path):
    exe = shutil.which("selfmanip")
    cmd = [exe] if exe else [sys.executable, "-m", "selfmanip"]
    ok = subprocess.run(cmd + ["sweep", "--t2=-0.05:0.05:3", "--out", str(tmp_path / "t.csv")],
                        capture_output=True, text=True, timeout=120)
    assert ok.returncode == 0, ok.stderr
    assert (tmp_path / "t.csv").read_text().startswith("strategy,t2_s,gear_ratio,")
    bad = subprocess.run(cmd + ["sweep", "--strategy", "??"], capture_output=True, text=True, timeout=120)
    assert bad.returncode == 2 and "strategy" in bad.stderr


def test_progress_bar_on_request(capsys):
    assert cli.main(["sweep", "--t2=-0.1:0.1:4", "--progress", "always"]) == 0
    err = capsys.readouterr().err
    assert "sweep [" in err and "4/4" in err
