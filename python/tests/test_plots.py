"""Plots: a synthetic sweep table (over t2 and over the gear ratio) and a leap each give a PNG;
the drawn robot agrees with the engine's contact points (independent kinematics)."""

import numpy as np
import pytest

import selfmanip
from selfmanip.leap import SWEEP_COLUMNS

pytest.importorskip("matplotlib")
from selfmanip import plots  # noqa: E402

PNG = b"\x89PNG\r\n\x1a\n"


def synthetic_table(t2, gears, seed=0):
    rng = np.random.default_rng(seed)
    rows = [(s, g, t) for s in ("++", "-+") for g in gears for t in t2]
    n = len(rows)
    words = np.array(["1010-0110-0101-0001-0000", "1010-1001-0101-0100-0000", ""])
    w = words[rng.integers(0, 3, n)]
    table = {c: rng.normal(size=n) for c in SWEEP_COLUMNS}
    table.update(strategy=np.array([r[0] for r in rows]), gear_ratio=np.array([r[1] for r in rows], dtype=float),
                 t2_s=np.array([r[2] for r in rows], dtype=float), word=w,
                 status=np.where(w == "", "zeno", "apex"), flew=w != "", error=np.full(n, ""), n_events=np.zeros(n, dtype=np.int64))
    return table


@pytest.mark.parametrize("t2, gears", [(np.linspace(-0.2, 0.2, 21), [28.0]), ([0.0], np.linspace(15, 40, 11)),
                                       (np.linspace(-0.2, 0.2, 5), [20.0, 28.0, np.nan])])
def test_sweep_figure_writes_a_png(tmp_path, t2, gears):
    out = plots.sweep_figure(synthetic_table(t2, gears), tmp_path / "s.png")
    assert open(out, "rb").read(8) == PNG


def test_sweep_figure_names_a_missing_column(tmp_path):
    t = synthetic_table([0.0], [28.0])
    del t["apex_x_m"]
    with pytest.raises(ValueError, match="apex_x_m"):
        plots.sweep_figure(t, tmp_path / "s.png")


@pytest.mark.parametrize("shape", ["stick", "half_circle"])
def test_drawn_legs_touch_the_engine_contact_points(shape, tmp_path):
    r = selfmanip.leap("++", 0.0, 28.0, {"leg_shape": shape}, dt=0.004)
    tr = r.trajectory
    checked = 0
    for k in range(len(tr.t_s)):
        lines = plots.robot_outline(r.params, tr.q[k])
        for c, name in enumerate(tr.contacts):
            p = tr.contact_points_m[k, c]
            if not name.endswith("_leg") or not np.all(np.isfinite(p)):
                continue
            leg = lines[3 + ["middle_leg", "rear_leg"].index(name)]
            if shape == "stick":
                assert leg[-1] == pytest.approx(p, abs=1e-9)  # the toe
            else:
                # the contact point lies on the drawn arc (densely resampled)
                d = np.min(np.hypot(*(leg - p).T))
                assert d < 0.5 * r.params["rho1"] * (np.pi / 24) * 0.6
            checked += 1
    assert checked > 0
    out = plots.plot_result(r, tmp_path / "strip.png")
    assert open(out, "rb").read(8) == PNG


# --- readable sweep plots (issue 17, item 7) ---------------------------------------------


def test_words_are_labelled_by_the_thesis_equations():
    """(3.2)-(3.7) by the ground reaction complex's own data: each word's full path (rest,
    the printed cells with the zero-time bridge cells restored, flight), as a leap reports it."""
    words = selfmanip.rhex.ground_reaction_complex()["leap_words"]
    assert [w["equation"] for w in words] == ["3.2", "3.3", "3.4", "3.5", "3.6", "3.7"]
    for w in words:
        full = "-".join(w["path"])
        printed = "-".join(["1010", *w["printed"], "0000"])
        for word in (full, printed):
            assert plots.word_label(word) == f"({w['equation']}) {word}", word
    # a word that is none of them keeps its cells as they are
    assert plots.word_label("1010-0110-0100-0101-0001-0000") == "1010-0110-0100-0101-0001-0000"
    assert plots.word_label("1010-0110-0101-0001-0000").startswith("(3.3)")


def test_long_chattering_words_are_folded():
    chatter = ["1010", "0110"] + ["0101", "0111"] * 6 + ["0001", "0000"]
    assert plots.fold_word(chatter) == "1010-0110-(0101-0111)x6-0001-0000"
    assert plots.word_label("-".join(chatter)) == "1010-0110-(0101-0111)x6-0001-0000"
    # without repeats, a long word keeps its ends and elides its middle
    cells = [format(i, "04b") for i in range(16)]
    folded = plots.fold_word(cells)
    assert folded.startswith("0000-0001-0010-0011-…+9…") and folded.endswith("1101-1110-1111")
    assert plots.fold_word(["1010", "0110", "0000"]) == "1010-0110-0000"


def _lines(ax):
    return [l for l in ax.get_lines() if len(l.get_xdata())]


def test_t2_by_gear_ratio_grid_is_drawn_as_heat_maps():
    import matplotlib.pyplot as plt
    from matplotlib.collections import QuadMesh

    fig = plots.build_sweep_figure(synthetic_table(np.linspace(-0.2, 0.2, 6), np.linspace(15, 40, 5)))
    axes = fig.axes
    maps = [ax for ax in axes if ax.get_xlabel() == "t2 (s)"]  # not the colour bars
    assert all(any(isinstance(c, QuadMesh) for c in ax.collections) for ax in maps)
    assert len(maps) == 2 * 4  # two strategies: height, displacement, pitch, words
    assert not any(_lines(ax) for ax in maps)
    plt.close(fig)


def test_extra_swept_parameters_are_separate_series_without_zigzag_joins():
    import matplotlib.pyplot as plt

    t2 = np.linspace(-0.2, 0.2, 9)
    table = synthetic_table(t2, [28.0])
    n = len(table["t2_s"])
    # the same points swept over a second parameter, rows shuffled
    both = {k: np.concatenate([v, v]) for k, v in table.items()}
    both["m_b"] = np.repeat([8.0, 9.0], n)
    both["status"] = np.full(2 * n, "apex")
    both["flew"] = np.full(2 * n, True)
    order = np.random.default_rng(5).permutation(2 * n)
    both = {k: v[order] for k, v in both.items()}
    fig = plots.build_sweep_figure(both)
    height = [ax for ax in fig.axes if ax.get_ylabel() == "apex height (m)"]
    assert len(height) == 2
    for ax in height:
        lines = _lines(ax)
        assert len(lines) == 2  # one per m_b
        for line in lines:
            x = np.asarray(line.get_xdata(), dtype=float)
            assert np.all(np.diff(x) > 0) and len(x) == len(t2)
    plt.close(fig)


def test_pitch_is_drawn_in_degrees():
    import matplotlib.pyplot as plt

    table = synthetic_table(np.linspace(-0.2, 0.2, 7), [28.0])
    table["status"] = np.full(len(table["t2_s"]), "apex")
    table["flew"] = np.full(len(table["t2_s"]), True)
    fig = plots.build_sweep_figure(table)
    labels = [ax.get_ylabel() for ax in fig.axes] + [ax.get_xlabel() for ax in fig.axes]
    assert "pitch at apex (deg)" in labels and not any("rad" in l for l in labels)
    ax = [a for a in fig.axes if a.get_ylabel() == "pitch at apex (deg)"][0]
    line = _lines(ax)[0]
    sel = table["strategy"] == "++"
    want = np.degrees(table["apex_phi_rad"][sel][np.argsort(table["t2_s"][sel])])
    np.testing.assert_allclose(line.get_ydata(), want)
    plt.close(fig)
