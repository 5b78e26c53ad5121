"""The README's Python and command-line snippets run as written, from the repository root's
point of view (its data paths are relative to the root; outputs go to a scratch directory).
Every ``python`` block runs, and every line of an ``sh`` block that starts with
``selfmanip `` exits 0 and writes the files it names."""

import contextlib
import io
import pathlib
import re
import shlex

from selfmanip import cli

ROOT = pathlib.Path(__file__).resolve().parents[2]
README = ROOT / "README.md"


def blocks(lang):
    return re.findall(rf"```{lang}\n(.*?)```", README.read_text(), flags=re.S)


def scratch_with_data(tmp_path, monkeypatch):
    """A scratch working directory in which the README's relative data paths resolve."""
    for name in ("crates", "tests"):
        (tmp_path / name).symlink_to(ROOT / name, target_is_directory=True)
    monkeypatch.chdir(tmp_path)


def test_readme_python_runs(tmp_path, monkeypatch):
    scratch_with_data(tmp_path, monkeypatch)
    code = blocks("python")
    assert code, "the README has no python block"
    for block in code:
        with contextlib.redirect_stdout(io.StringIO()):
            exec(compile(block, str(README), "exec"), {})
    assert (tmp_path / "hopper.mcap").stat().st_size > 0


def test_readme_commands_run(tmp_path, monkeypatch):
    scratch_with_data(tmp_path, monkeypatch)
    lines = [l for b in blocks("sh") for l in b.splitlines() if l.startswith("selfmanip ")]
    assert len(lines) >= 4, lines
    for line in lines:
        buf = io.StringIO()
        with contextlib.redirect_stdout(buf):
            code = cli.main(shlex.split(line)[1:])
        assert code == 0, line
        for word in shlex.split(line):
            if word.endswith((".csv", ".png", ".mcap")) and not word.startswith("-"):
                assert (tmp_path / word).stat().st_size > 0, (line, word)
