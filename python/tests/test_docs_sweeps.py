"""The commands and code in docs/sweeps.md run as written (in a scratch directory): every
`selfmanip ...` line exits 0 and produces its files; the Python block runs."""

import contextlib
import io
import pathlib
import re
import shlex

import pytest

from selfmanip import cli

DOC = pathlib.Path(__file__).resolve().parents[2] / "docs" / "sweeps.md"


def blocks(lang):
    return re.findall(rf"```{lang}\n(.*?)```", DOC.read_text(), flags=re.S)


def test_documented_commands_run(tmp_path, monkeypatch):
    pytest.importorskip("matplotlib")
    pytest.importorskip("pyarrow")
    monkeypatch.chdir(tmp_path)
    lines = [l for b in blocks("sh") for l in b.splitlines() if l.startswith("selfmanip ")]
    assert len(lines) >= 6
    for line in lines:
        redirect = None
        if ">" in line:
            line, redirect = (s.strip() for s in line.split(">", 1))
        buf = io.StringIO()
        with contextlib.redirect_stdout(buf):
            code = cli.main(shlex.split(line)[1:])
        assert code == 0, line
        if redirect:
            pathlib.Path(redirect).write_text(buf.getvalue())
        for word in shlex.split(line):
            if word.endswith((".csv", ".parquet", ".png", ".mcap")) and not word.startswith("-"):
                assert (tmp_path / word).stat().st_size > 0, (line, word)


def test_documented_python_runs(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    runnable = [b for b in blocks("python") if "Client(" not in b]
    assert runnable
    for b in runnable:
        exec(compile(b, str(DOC), "exec"), {})
    assert (tmp_path / "leap.mcap").stat().st_size > 0


def test_examples_run_small(tmp_path):
    pytest.importorskip("matplotlib")
    import importlib.util

    root = pathlib.Path(__file__).resolve().parents[2] / "python" / "examples"
    for name, argv in (("chapter3_sweeps", ["--n", "5"]), ("gear_ratio_sweep", ["--gears", "20:30:3"])):
        spec = importlib.util.spec_from_file_location(name, root / f"{name}.py")
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        assert mod.main(argv + ["--out-dir", str(tmp_path)]) == 0
        assert (tmp_path / f"{name.replace('_sweeps', '_sweep')}.csv").stat().st_size > 0
        assert (tmp_path / f"{name.replace('_sweeps', '_sweep')}.png").stat().st_size > 0
