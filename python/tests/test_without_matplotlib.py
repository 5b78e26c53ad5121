"""Without matplotlib (a plain ``pip install``, no ``plot`` extra), the main job
``python3 -m selfmanip`` writes its CSV and says how to get the figure instead of a
traceback, and a figure asked for by name raises a typed error that says the same (issue 30,
item 7). matplotlib is hidden in a subprocess (``sys.modules["matplotlib"] = None``, which
makes every ``import matplotlib`` fail as if it were not installed)."""

from __future__ import annotations

import csv
import subprocess
import sys
import textwrap

HIDE = "import sys; sys.modules['matplotlib'] = None\n"


def run_hidden(code: str, cwd) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", HIDE + textwrap.dedent(code)], cwd=cwd, capture_output=True,
                          text=True, timeout=600)


def test_main_job_writes_its_csv_and_says_how_to_get_the_figure(tmp_path) -> None:
    p = run_hidden("""
        import runpy
        sys.argv = ["selfmanip", "chapter3", "--n", "3", "--out-dir", "out"]
        runpy.run_module("selfmanip", run_name="__main__")
        """, tmp_path)
    assert p.returncode == 0, p.stderr
    assert "Traceback" not in p.stderr
    rows = list(csv.DictReader((tmp_path / "out" / "chapter3_sweep.csv").open()))
    assert len(rows) == 4 * 3                     # four strategies x three values of t2
    assert not (tmp_path / "out" / "chapter3_sweep.png").exists()
    assert "pip install matplotlib" in p.stdout
    assert "selfmanip plot" in p.stdout and "chapter3_sweep.csv" in p.stdout


def test_a_figure_asked_for_raises_a_typed_error(tmp_path) -> None:
    p = run_hidden("""
        import selfmanip
        from selfmanip.plots import PlottingUnavailableError
        e = selfmanip.simulate("%s", None, [0.5, -1.0, 0.0, -0.451, 0.0], t_final=0.05)
        try:
            e.plot("x.png")
        except PlottingUnavailableError as err:
            assert isinstance(err, ImportError) and isinstance(err, selfmanip.SelfmanipError)
            print("typed:", err)
        """ % (__import__("pathlib").Path(__file__).resolve().parents[2]
               / "crates" / "selfmanip-sim" / "examples" / "data" / "hopper.toml").as_posix(), tmp_path)
    assert p.returncode == 0, p.stderr
    assert p.stdout.startswith("typed:") and "pip install matplotlib" in p.stdout


def test_the_plot_command_says_what_to_install(tmp_path) -> None:
    (tmp_path / "t.csv").write_text("strategy,t2_s,apex_z_m\n++,0.0,0.1\n")
    p = run_hidden("""
        from selfmanip.cli import main
        raise SystemExit(main(["plot", "t.csv", "--out", "t.png"]))
        """, tmp_path)
    assert p.returncode == 2
    assert "Traceback" not in p.stderr and "pip install matplotlib" in p.stderr
