"""PNG plots of leaps and sweeps (matplotlib, imported lazily with the ``Agg`` backend;
install the ``plot`` extra). Angles are in degrees in every figure (as in the section-4.3
figures of :mod:`selfmanip.figures`); tables and results keep radians.

* :func:`sweep_figure` — thesis Figs. 3.4/3.5 style: apex height, forward displacement and
  pitch against ``t2`` for each strategy, each point coloured by its leap word; one series per
  combination of the other swept values (gear ratio, any swept parameter), each drawn in its
  own line style and never joined to another; against the gear ratio instead when a sweep
  has a single ``t2``; a ``t2`` x gear-ratio grid as heat maps (with a map of the words);
* :func:`word_label` — a leap word for a legend: the thesis's equation (3.2)-(3.7) when it is
  one of chapter 3's words, long chattering words folded (``(0101-0111)x6``);
* :func:`execution_figure` — one execution of any robot (:func:`selfmanip.simulate`): body
  height and forward position, pitch and joint angles, contact normal forces and joint
  torques against time, events marked;
* :func:`simulation_sweep_figure` — a sweep of any robot (:func:`selfmanip.sweep` with a
  robot): apex height, end position and impact losses against the first swept parameter, one
  series per value of the others, points coloured by status;
* :func:`leap_strip` — a keyframe strip in the style of Fig. 5.1: the body, the legs and the
  contact forces (ground on robot, arrows) at evenly spaced times.

:func:`plot_file` dispatches on the file: a sweep table (``.csv``/``.parquet``), a leap
(``.json`` from ``selfmanip leap --json``) or an MCAP log (``.mcap``).
"""

from __future__ import annotations

import json
import math
import os
from typing import TYPE_CHECKING, Any, Mapping, Sequence

import numpy as np

from . import _native
from ._tables import read_table, write_atomically
from .errors import InvalidInputError, SelfmanipError
from .leap import LeapResult, Trajectory

if TYPE_CHECKING:
    import matplotlib.figure

__all__ = ["PlottingUnavailableError", "INSTALL_HINT", "sweep_figure", "build_sweep_figure", "word_label", "fold_word", "leap_strip", "plot_file", "load_leap",
           "execution_figure", "simulation_sweep_figure"]

#: Length of a force arrow (m per N) in :func:`leap_strip`.
FORCE_SCALE_M_PER_N = 0.004
_DEG = 180.0 / math.pi
#: Words beyond this many in a legend are drawn grey as "other words".
MAX_LEGEND_WORDS = 12
#: Columns of a sweep table that are results, not swept inputs.
_RESULT_COLUMNS = {"apex_z_m", "apex_x_m", "apex_phi_rad", "apex_xdot_m_s", "apex_phidot_rad_s",
                   "apex_zdot_m_s", "apex_t_s", "word", "status", "flew", "n_events", "error"}


class PlottingUnavailableError(SelfmanipError, ImportError):
    """matplotlib is not installed (a plain ``pip install`` leaves it out): the message says
    how to install it; the tables and logs that need no figure are written all the same."""


#: How to get the figures: the ``plot`` extra, or matplotlib itself.
INSTALL_HINT = 'python3 -m pip install matplotlib (or, in a checkout, python3 -m pip install ".[plot]")'


def save_figure(fig: Any, path: str | os.PathLike[str]) -> None:
    """``fig`` as an image file at ``path``, in the format its suffix names (PNG without
    one), written atomically (:func:`selfmanip._tables.write_atomically`): a run stopped
    midway leaves no partial image under ``path``."""
    path = os.fspath(path)
    suffix = os.path.splitext(path)[1].lstrip(".").lower()
    write_atomically(path, lambda tmp: fig.savefig(tmp, dpi=110, format=suffix or "png"))


def _pyplot():
    """``matplotlib.pyplot`` on the ``Agg`` backend, or :class:`PlottingUnavailableError`."""
    try:
        import matplotlib
    except ImportError as e:
        raise PlottingUnavailableError(f"figures need matplotlib, which is not installed: {INSTALL_HINT}") from e

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def fold_word(cells: Sequence[str], max_items: int = 8) -> str:
    """A word's cells joined by ``-`` with repeated runs folded: a block of one to four cells
    repeated ``k >= 2`` times in a row becomes ``(a-b)xk``; if more than ``max_items`` items
    remain, the middle is elided (``…+n…``), keeping the first four and the last three.

    >>> fold_word(["1010", "0110"] + ["0101", "0111"] * 6 + ["0001", "0000"])
    '1010-0110-(0101-0111)x6-0001-0000'
    """
    cells = list(cells)
    items: list[str] = []
    i = 0
    while i < len(cells):
        best = (1, 1)  # (block length, repeats)
        for length in range(1, 5):
            block = cells[i:i + length]
            if len(block) < length:
                break
            k = 1
            while cells[i + k * length:i + (k + 1) * length] == block:
                k += 1
            if k >= 2 and k * length > best[0] * best[1]:
                best = (length, k)
        length, k = best
        if k >= 2:
            block = "-".join(cells[i:i + length])
            items.append(f"({block})x{k}" if length > 1 else f"{block}x{k}")
        else:
            items.append(cells[i])
        i += length * k
    if len(items) > max_items:
        hidden = len(items) - 7
        items = items[:4] + [f"…+{hidden}…"] + items[-3:]
    return "-".join(items)


def _flew(cols: Mapping[str, np.ndarray]) -> np.ndarray:
    """The points whose leap flew: the table's ``flew`` column (a table without one: those
    that ended at their apex)."""
    if "flew" in cols:
        return np.asarray(cols["flew"], dtype=bool)
    return np.asarray(cols["status"]).astype(str) == "apex"


def word_label(word: str, max_items: int = 8) -> str:
    """A leap word for a legend: ``"(3.3) 1010-0110-0101-0001-0000"`` when the word is chapter
    3's (3.2)-(3.7) (matched on its cells as the ground reaction complex prints them), the
    word folded by :func:`fold_word` otherwise.

    >>> word_label("1010-0110-0101-0001-0000")
    '(3.3) 1010-0110-0101-0001-0000'
    """
    cells = [c for c in str(word).split("-") if c]
    if not cells:
        return "(no word)"
    try:
        eq = _native.leap_word_equation(cells)
    except ValueError:
        eq = None
    folded = fold_word(cells, max_items)
    return f"({eq}) {folded}" if eq else folded


def _varying(cols: Mapping[str, np.ndarray], key: str, sel: np.ndarray | None = None) -> bool:
    v = cols[key] if sel is None else cols[key][sel]
    if v.dtype.kind == "f":
        return len(np.unique(v[~np.isnan(v)])) + int(np.isnan(v).any()) > 1
    return len(set(v.tolist())) > 1


def _fmt(key: str, v: Any) -> str:
    if key == "gear_ratio":
        return "saturated torque" if isinstance(v, float) and math.isnan(v) else f"G={v:g}"
    if key == "t2_s":
        return f"t2={v:g} s"
    return f"{key}={v:g}" if isinstance(v, (float, np.floating)) else f"{key}={v}"


def _series(cols: Mapping[str, np.ndarray], sel: np.ndarray, keys: list[str]) -> list[tuple[str, np.ndarray]]:
    """The rows ``sel`` split by the values of ``keys``: ``[(label, mask), ...]``."""
    if not keys:
        return [("", sel)]
    out: list[tuple[str, np.ndarray]] = []
    rows = np.flatnonzero(sel)
    seen: dict[tuple, list[int]] = {}
    for r in rows:
        key = tuple(("nan" if isinstance(cols[k][r], float) and math.isnan(cols[k][r]) else cols[k][r].item()
                     if hasattr(cols[k][r], "item") else cols[k][r]) for k in keys)
        seen.setdefault(key, []).append(r)
    for key, idx in seen.items():
        mask = np.zeros(len(sel), dtype=bool)
        mask[idx] = True
        label = ", ".join(_fmt(k, cols[k][idx[0]].item() if hasattr(cols[k][idx[0]], "item") else cols[k][idx[0]])
                          for k in keys)
        out.append((label, mask))
    return out


def sweep_figure(table: Mapping[str, Any], out_path: str | os.PathLike, title: str | None = None) -> str:
    """Draws a sweep table (a dict of columns or a pandas DataFrame) to a PNG and returns the
    path (see :func:`build_sweep_figure`)."""
    plt = _pyplot()
    fig = build_sweep_figure(table, title)
    save_figure(fig, out_path)
    plt.close(fig)
    return os.fspath(out_path)


def build_sweep_figure(table: Mapping[str, Any], title: str | None = None) -> "matplotlib.figure.Figure":
    """The matplotlib figure of a sweep table: one row of panels per strategy; heat maps over
    ``t2`` x gear ratio when the sweep is such a grid (at least 4 values of each, nothing else
    swept), otherwise one series per combination of the other swept values against ``t2`` (or
    the gear ratio when ``t2`` is fixed). Pitch in degrees."""
    plt = _pyplot()
    cols = {k: np.asarray(table[k]) for k in table.keys()}
    for need in ("strategy", "t2_s", "gear_ratio", "apex_z_m", "apex_x_m", "apex_phi_rad", "word", "status"):
        if need not in cols:
            raise InvalidInputError(f"sweep table has no `{need}` column", need)
    if len(cols["strategy"]) == 0:
        raise InvalidInputError("the sweep table has no rows", "table")
    cols["gear_ratio"] = cols["gear_ratio"].astype(float)
    cols["t2_s"] = cols["t2_s"].astype(float)
    strategies = [s for s in ("++", "+-", "-+", "--") if s in set(cols["strategy"].astype(str))]
    strategies += sorted(set(cols["strategy"].astype(str)) - set(strategies))
    ok_all = _flew(cols)
    labels = np.array([word_label(w) for w in cols["word"].astype(str)], dtype=object)
    # words by frequency among the ok points; the rarest beyond the legend's size are grey
    counts: dict[str, int] = {}
    for lab in labels[ok_all]:
        counts[lab] = counts.get(lab, 0) + 1
    words = sorted(counts, key=lambda w: (-counts[w], w))
    shown, other = words[:MAX_LEGEND_WORDS], words[MAX_LEGEND_WORDS:]
    cmap = plt.get_cmap("tab10" if len(shown) <= 10 else "tab20")
    colour = {w: cmap(i % cmap.N) for i, w in enumerate(shown)}
    colour.update({w: (0.6, 0.6, 0.6, 1.0) for w in other})
    extra = [k for k in cols if k not in _RESULT_COLUMNS and k not in ("strategy", "t2_s", "gear_ratio")
             and _varying(cols, k)]
    finite_g = ~np.isnan(cols["gear_ratio"])
    n_t2 = len(np.unique(cols["t2_s"]))
    n_g = len(np.unique(cols["gear_ratio"][finite_g]))
    heat = n_t2 >= 4 and n_g >= 4 and not extra
    handles = [plt.Line2D([], [], marker="o", ls="", color=colour[w], label=w) for w in shown]
    if other:
        handles.append(plt.Line2D([], [], marker="o", ls="", color=colour[other[0]],
                                  label=f"{len(other)} other words"))
    handles.append(plt.Line2D([], [], marker="x", ls="", color="0.4", label="no apex (did not fly)"))
    legend_in = 0.3 + 0.2 * math.ceil(len(handles) / 3)  # the word legend's height (inches)
    if heat:
        fig = _heat_maps(plt, cols, strategies, labels, shown, colour, finite_g, legend_in)
    else:
        fig = _series_figure(plt, cols, strategies, labels, colour, extra, legend_in)
    fig.legend(handles=handles, loc="lower center", ncol=min(3, len(handles)), fontsize=8,
               title="leap word ((3.2)-(3.7): thesis chapter 3)")
    fig.suptitle(title or ("Leap sweep: apex height, displacement and pitch over t2 and the gear ratio"
                           if heat else "Leap sweep: apex height, displacement and pitch (cf. thesis Figs. 3.4-3.5)"))
    height = fig.get_figheight()
    fig.tight_layout(rect=(0, (legend_in + 0.15) / height, 1, 1 - 0.45 / height))
    return fig


_PANELS = [("apex_z_m", "apex height (m)", 1.0), ("apex_x_m", "displacement (m)", 1.0),
           ("apex_phi_rad", "pitch at apex (deg)", _DEG)]
_STYLES = ["-", "--", ":", "-."]
_MARKERS = ["o", "s", "^", "D", "v", "P", "X", "*"]


def _series_figure(plt, cols, strategies, labels, colour, extra, legend_in):
    by_gear = not _varying(cols, "t2_s") and _varying(cols, "gear_ratio")
    xkey, xlabel = ("gear_ratio", "gear ratio G") if by_gear else ("t2_s", "t2 (s)")
    panels = list(_PANELS)
    if by_gear:
        panels[2] = ("apex_xdot_m_s", "forward speed at apex (m/s)", 1.0)
    series_keys = [k for k in ("gear_ratio", "t2_s") if k != xkey and _varying(cols, k)] + extra
    fig, axes = plt.subplots(len(strategies), 3, figsize=(13, 2.8 * len(strategies) + 0.6 + legend_in),
                             squeeze=False, sharex=True)
    ok_all = _flew(cols)
    series_handles: dict[str, Any] = {}
    for i, s in enumerate(strategies):
        sel = cols["strategy"].astype(str) == s
        for si, (slabel, m) in enumerate(_series(cols, sel, series_keys)):
            style, marker = _STYLES[si % len(_STYLES)], _MARKERS[(si // len(_STYLES)) % len(_MARKERS)]
            order = np.argsort(cols[xkey][m], kind="stable")
            x = cols[xkey][m][order].astype(float)
            ok = ok_all[m][order]
            lab = labels[m][order]
            for j, (key, ylabel, scale) in enumerate(panels):
                ax = axes[i, j]
                if key not in cols:
                    ax.set_visible(False)
                    continue
                y = cols[key][m][order].astype(float) * scale
                yline = np.where(ok, y, np.nan)  # a failed point breaks the line
                (line,) = ax.plot(x, yline, style, color="0.55", lw=0.9, zorder=1)
                if slabel and slabel not in series_handles:
                    series_handles[slabel] = plt.Line2D([], [], ls=style, marker=marker, color="0.4",
                                                        label=slabel)
                for word in dict.fromkeys(lab[ok]):
                    k = (lab == word) & ok & np.isfinite(y)
                    if k.any():
                        ax.scatter(x[k], y[k], s=16, marker=marker, color=colour.get(word, "k"), zorder=2)
                bad = ~ok
                if bad.any():
                    lo = np.nanmin(y[ok]) if (ok & np.isfinite(y)).any() else 0.0
                    ax.scatter(x[bad], np.full(bad.sum(), lo), marker="x", s=12, color="0.4", zorder=2)
                ax.set_ylabel(ylabel)
                if j == 0:
                    ax.set_title(f"strategy ({s[0]}, {s[1]})", loc="left", fontsize=10)
                if i == len(strategies) - 1:
                    ax.set_xlabel(xlabel)
    if len(series_handles) > 1:
        axes[0, -1].legend(handles=list(series_handles.values()), fontsize=7, loc="best", title="series",
                           title_fontsize=7)
    return fig


def _heat_maps(plt, cols, strategies, labels, shown, colour, finite_g, legend_in):
    from matplotlib.colors import ListedColormap

    t2 = np.unique(cols["t2_s"])
    gears = np.unique(cols["gear_ratio"][finite_g])
    fig, axes = plt.subplots(len(strategies), 4, figsize=(16, 3.2 * len(strategies) + 0.6 + legend_in),
                             squeeze=False)
    ok_all = _flew(cols)
    word_index = {w: k for k, w in enumerate(shown)}
    word_cmap = ListedColormap([colour[w] for w in shown] + [(0.6, 0.6, 0.6, 1.0)]).with_extremes(bad="white")
    for i, s in enumerate(strategies):
        sel = (cols["strategy"].astype(str) == s) & finite_g
        ti = np.searchsorted(t2, cols["t2_s"][sel])
        gi = np.searchsorted(gears, cols["gear_ratio"][sel])
        for j, (key, label, scale) in enumerate(_PANELS):
            grid = np.full((len(gears), len(t2)), np.nan)
            v = np.where(ok_all[sel], cols[key][sel].astype(float) * scale, np.nan)
            grid[gi, ti] = v
            ax = axes[i, j]
            cmap = plt.get_cmap("viridis").with_extremes(bad="0.85")
            im = ax.pcolormesh(t2, gears, np.ma.masked_invalid(grid), shading="nearest", cmap=cmap)
            fig.colorbar(im, ax=ax, label=label)
            ax.set_xlabel("t2 (s)")
            ax.set_ylabel("gear ratio G")
            if j == 0:
                ax.set_title(f"strategy ({s[0]}, {s[1]}); grey: no apex", loc="left", fontsize=10)
        codes = np.full((len(gears), len(t2)), np.nan)
        lab = labels[sel]
        ok = ok_all[sel]
        codes[gi, ti] = [word_index.get(w, len(shown)) if o else np.nan for w, o in zip(lab, ok)]
        ax = axes[i, 3]
        ax.pcolormesh(t2, gears, np.ma.masked_invalid(codes), shading="nearest", cmap=word_cmap,
                      vmin=-0.5, vmax=len(shown) + 0.5)
        ax.set_xlabel("t2 (s)")
        ax.set_ylabel("gear ratio G")
        ax.set_title("leap word (legend below)", fontsize=9)
    return fig


def _body_to_world(q_body: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Body-frame ``(x, z)`` points to world (NED) with ``q_body = (x, z, phi)``:
    ``p_w = p_b0 + R(phi)^T p`` with the conventions' ``R``."""
    x, z, phi = q_body
    c, s = math.cos(phi), math.sin(phi)
    return np.column_stack([x + c * pts[:, 0] + s * pts[:, 1], z - s * pts[:, 0] + c * pts[:, 1]])


def _leg_outline(shape: str, rho: float) -> np.ndarray:
    if shape == "stick":
        return np.array([[0.0, 0.0], [0.0, rho]])
    a = np.linspace(0.0, -math.pi, 25)  # outward normals (sin a, cos a), toe to hip
    return np.column_stack([0.5 * rho * np.sin(a), 0.5 * rho + 0.5 * rho * np.cos(a)])


def _pairs(params: Mapping[str, Any]) -> list[str]:
    order = {"front": 0, "middle": 1, "rear": 2}
    return sorted(params["pairs"], key=order.__getitem__)


def robot_outline(params: Mapping[str, Any], q: np.ndarray) -> list[np.ndarray]:
    """World (NED) polylines of the body and legs at ``q = [theta..., x, z, phi]``."""
    pairs = _pairs(params)
    nb = len(pairs)
    qb = np.asarray(q[nb:nb + 3], dtype=float)
    hip = {"front": params["l1"], "middle": 0.0, "rear": -params["l2"]}
    rho = {"front": params["rho1"], "middle": params["rho1"], "rear": params["rho2"]}
    rb = params["rho_b"]
    a = np.linspace(0, 2 * math.pi, 25)
    out = [_body_to_world(qb, np.array([[params["l1"], 0.0], [-params["l2"], 0.0]]))]
    for x0 in (params["l1"], -params["l2"]):
        out.append(_body_to_world(qb, np.column_stack([x0 + rb * np.cos(a), rb * np.sin(a)])))
    for i, p in enumerate(pairs):
        th = float(q[i])
        leg = _leg_outline(params["leg_shape"], rho[p])
        # leg frame -> body: x_l along (cos th, sin th), z_l along (-sin th, cos th)
        body = np.column_stack([hip[p] + leg[:, 0] * math.cos(th) - leg[:, 1] * math.sin(th),
                                leg[:, 0] * math.sin(th) + leg[:, 1] * math.cos(th)])
        out.append(_body_to_world(qb, body))
    return out


def leap_strip(params: Mapping[str, Any], trajectory: Trajectory, out_path: str | os.PathLike,
               n_frames: int = 6, title: str | None = None, terrain: Mapping[str, Any] | None = None) -> str:
    """Keyframe strip of a leap (cf. thesis Fig. 5.1), heights up; returns the path."""
    plt = _pyplot()
    t = np.asarray(trajectory.t_s)
    if len(t) == 0:
        raise InvalidInputError("the trajectory has no samples", "trajectory")
    idx = np.unique(np.round(np.linspace(0, len(t) - 1, max(1, n_frames))).astype(int))
    q = np.asarray(trajectory.q)
    pts = np.asarray(trajectory.contact_points_m)
    f = np.asarray(trajectory.contact_forces_n)
    lines_all = [robot_outline(params, q[k]) for k in idx]
    xs = np.concatenate([np.concatenate([l[:, 0] for l in ls]) for ls in lines_all])
    zs = np.concatenate([np.concatenate([-l[:, 1] for l in ls]) for ls in lines_all])
    span_x = max(np.ptp(xs), 0.5)
    fig, axes = plt.subplots(1, len(idx), figsize=(2.6 * len(idx), 3.2), sharey=True, squeeze=False)
    for ax, k, lines in zip(axes[0], idx, lines_all):
        xc = float(np.mean(lines[0][:, 0]))
        half = 0.45 * min(span_x, 1.0) + 0.25
        gx = np.linspace(xc - half, xc + half, 50)
        gz = np.zeros_like(gx)
        if terrain and terrain.get("kind") == "ledge":
            d = terrain["distance_m"]  # the face: a ledge ahead (d > 0) or behind (d < 0)
            gz = np.where(gx >= d if d > 0 else gx <= d, terrain["height_m"], 0.0)
        ax.fill_between(gx, gz, min(-0.05, zs.min() - 0.05), color="0.85", lw=0)
        ax.plot(gx, gz, color="0.3", lw=1)
        for j, l in enumerate(lines):
            ax.plot(l[:, 0], -l[:, 1], color="tab:blue" if j < 3 else "k", lw=2.5 if j == 0 else 1.5)
        for c in range(pts.shape[1] if pts.ndim == 3 else 0):
            p, fc = pts[k, c], f[k, c]
            if np.all(np.isfinite(p)) and np.all(np.isfinite(fc)):
                ax.annotate("", xy=(p[0] + FORCE_SCALE_M_PER_N * fc[0], -(p[1] + FORCE_SCALE_M_PER_N * fc[1])),
                            xytext=(p[0], -p[1]), arrowprops=dict(arrowstyle="->", color="tab:red", lw=1.5))
        ax.set_xlim(xc - half, xc + half)
        ax.set_aspect("equal")
        ax.set_title(f"t = {t[k]:.3f} s\n{trajectory.mode[k]}", fontsize=9)
        ax.set_xlabel("x (m)")
    axes[0, 0].set_ylabel("height (m)")
    axes[0, 0].set_ylim(min(-0.05, zs.min() - 0.05), max(0.3, zs.max() + 0.1))
    fig.suptitle(title or "Leap keyframes (contact forces: ground on robot, "
                          f"{FORCE_SCALE_M_PER_N * 100:g} cm per N)", fontsize=10)
    fig.tight_layout()
    save_figure(fig, out_path)
    plt.close(fig)
    return os.fspath(out_path)


def load_leap(path: str | os.PathLike) -> tuple[dict[str, Any], Trajectory, dict[str, Any]]:
    """``(params, trajectory, info)`` from a leap JSON (``selfmanip leap --json``) or MCAP log."""
    p = os.fspath(path)
    if os.path.exists(p) and os.path.getsize(p) == 0:
        raise InvalidInputError(f"{p}: the file is empty (expected a leap from `selfmanip leap --json` or "
                                "`--mcap`)", "path")
    if p.endswith(".json"):
        with open(p, encoding="utf-8") as fh:
            try:
                d = json.load(fh)
            except json.JSONDecodeError as e:
                raise InvalidInputError(f"{p}: not a leap JSON file (from `selfmanip leap --json`): {e}",
                                        "path") from None
        if not isinstance(d, dict) or "params" not in d:
            raise InvalidInputError(f"{p}: not a leap JSON file (from `selfmanip leap --json`): no `params`", "path")
        if not d.get("trajectory"):
            raise InvalidInputError(f"{p}: the leap has no trajectory", "path")
        tr = d["trajectory"]
        nan = lambda a: np.asarray([[[np.nan if v is None else v for v in c] for c in row] for row in a], dtype=float)
        traj = Trajectory(t_s=np.asarray(tr["t_s"], dtype=float), q=np.asarray(tr["q"], dtype=float),
                          qd=np.asarray(tr["qd"], dtype=float), mode=list(tr["mode"]),
                          contacts=list(tr["contacts"]), contact_points_m=nan(tr["contact_points_m"]),
                          contact_forces_n=nan(tr["contact_forces_n"]))
        return d["params"], traj, {k: d.get(k) for k in ("strategy", "t2_s", "gear_ratio", "word", "status", "config")}
    if p.endswith(".mcap"):
        from mcap.reader import make_reader

        t, q, qd, mode, pts, frc, contacts = [], [], [], [], [], [], []
        meta: dict[str, str] = {}
        with open(p, "rb") as fh:
            try:
                reader = make_reader(fh)
                for m in reader.iter_metadata():
                    if m.name == "selfmanip":
                        meta = dict(m.metadata)
                fh.seek(0)
                reader = make_reader(fh)
                for _schema, channel, msg in reader.iter_messages(topics=["/state", "/contact_forces"]):
                    d = json.loads(msg.data)
                    if channel.topic == "/state":
                        t.append(d["t_s"]); q.append(d["q"]); qd.append(d["qd"]); mode.append(d["mode"])
                    else:
                        contacts = [c["name"] for c in d["contacts"]]
                        pts.append([c["point_m"] or [np.nan, np.nan] for c in d["contacts"]])
                        frc.append([c["force_n"] or [np.nan, np.nan] for c in d["contacts"]])
            except Exception as e:  # the mcap reader raises its own types for a file that is not MCAP
                raise InvalidInputError(f"{p}: not a leap MCAP log ({type(e).__name__}: {e})", "path") from None
        if "params" not in meta:
            raise InvalidInputError(f"{p}: no selfmanip metadata with the parameters", "path")
        traj = Trajectory(t_s=np.asarray(t), q=np.asarray(q), qd=np.asarray(qd), mode=mode, contacts=contacts,
                          contact_points_m=np.asarray(pts, dtype=float), contact_forces_n=np.asarray(frc, dtype=float))
        info = {k: meta.get(k) for k in ("strategy", "t2_s", "gear_ratio", "word", "status")}
        info["config"] = json.loads(meta["config"]) if "config" in meta else None
        return json.loads(meta["params"]), traj, info
    raise InvalidInputError(f"{p}: expected a .json or .mcap leap", "path")


def plot_result(result: LeapResult, out_path: str | os.PathLike, n_frames: int = 6) -> str:
    """:func:`leap_strip` of a :class:`selfmanip.leap.LeapResult`."""
    if result.trajectory is None:
        raise InvalidInputError("this result has no trajectory: run leap(..., dt=...)", "dt")
    return leap_strip(result.params, result.trajectory, out_path, n_frames,
                      title=f"leap {result.strategy} t2={result.t2_s:g} s: {result.word} ({result.status})",
                      terrain=result.config.get("terrain"))


def plot_file(path: str | os.PathLike, out_path: str | os.PathLike) -> str:
    """A sweep table (.csv/.parquet) → :func:`sweep_figure`; a leap (.json/.mcap) →
    :func:`leap_strip`."""
    p = os.fspath(path)
    if not os.path.exists(p):
        raise InvalidInputError(f"no such file: {p}", "path")
    if p.endswith((".csv", ".parquet")):
        table = read_table(p)
        if "strategy" not in table and "status" in table:
            return simulation_sweep_figure(table, out_path)  # a sweep of any robot
        return sweep_figure(table, out_path)
    params, traj, info = load_leap(p)
    title = None
    if info.get("strategy"):
        title = f"leap {info['strategy']} t2={info.get('t2_s')} s: {info.get('word')} ({info.get('status')})"
    cfg = info.get("config") or {}
    return leap_strip(params, traj, out_path, title=title, terrain=cfg.get("terrain"))


_EVENT_COLOURS = {"touchdown": "tab:red", "liftoff": "tab:green", "slip": "tab:orange", "stick": "tab:purple",
                  "apex": "tab:blue"}


def execution_figure(execution: Any, out_path: str | os.PathLike | None = None, dt: Any = None,
                     title: str | None = None) -> "matplotlib.figure.Figure":
    """One execution of any robot (a :class:`selfmanip.simulation.Execution`) against time:
    body height ``-z`` and forward position ``x``; pitch and joint angles (degrees); the
    normal force of the ground at each contact (``-lam_n``, positive when it pushes) and the
    joint torques. Events are vertical lines coloured by kind. Saved as PNG when ``out_path``
    is given (the figure is returned either way)."""
    from .leap import DEFAULT

    plt = _pyplot()
    tr = execution.trajectory(DEFAULT if dt is None else dt)
    names = tr.q_names
    ix, iz, ip = names.index("x"), names.index("z"), names.index("phi")
    nj = ip - 2 if ip >= 2 else 0
    fig, axes = plt.subplots(3, 1, figsize=(8, 8.5), sharex=True)
    ax = axes[0]
    ax.plot(tr.t_s, -tr.q[:, iz], label="height -z (m)")
    ax.plot(tr.t_s, tr.q[:, ix], label="forward x (m)")
    ax.set_ylabel("m")
    ax.legend(loc="best", fontsize=8)
    ax = axes[1]
    ax.plot(tr.t_s, tr.q[:, ip] * _DEG, label="pitch phi", color="k")
    for j in range(min(nj, len(names))):
        ax.plot(tr.t_s, tr.q[:, j] * _DEG, label=names[j], lw=1)
    ax.set_ylabel("angle (deg)")
    ax.legend(loc="best", fontsize=8, ncol=2)
    ax = axes[2]
    for c, name in enumerate(tr.contacts):
        pts = tr.contact_points_m[:, c, 0]
        if np.all(np.isnan(pts)):
            continue
        f = tr.contact_forces_n[:, c, 1]
        ax.plot(tr.t_s, np.where(np.isnan(f), 0.0, -f), label=f"{name} normal (N)")
    if tr.tau.size:
        ax2 = ax.twinx()
        for j in range(tr.tau.shape[1]):
            ax2.plot(tr.t_s, tr.tau[:, j], ls=":", lw=1, label=f"tau {names[j]}")
        ax2.set_ylabel("joint torque (N m)")
        ax2.legend(loc="upper right", fontsize=7)
    ax.set_ylabel("ground force (N)")
    ax.set_xlabel("t (s)")
    ax.legend(loc="upper left", fontsize=8)
    for e in execution.events:
        for a in axes:
            a.axvline(e["t_s"], color=_EVENT_COLOURS.get(e["kind"], "0.6"), lw=0.6, alpha=0.6)
    fig.suptitle(title or f"{execution.robot_name or 'robot'}: {execution.status}, word "
                 f"{fold_word(execution.word)}", fontsize=10)
    fig.tight_layout()
    if out_path is not None:
        save_figure(fig, out_path)
        plt.close(fig)
    return fig


#: Result columns of a sweep of any robot (the rest are swept parameters).
_SIM_RESULT_PREFIXES = ("apex_", "landing_", "end_")
_SIM_RESULT_COLUMNS = {"status", "error", "word", "mode_end", "n_events", "t_end_s", "flight_time_s",
                       "impact_loss_j"}


def simulation_sweep_figure(table: Mapping[str, Any], out_path: str | os.PathLike,
                            title: str | None = None) -> str:
    """A sweep of any robot: apex height ``apex_z_m``, forward end position and impact losses
    against the first swept parameter; one series per combination of the other swept values
    (never joined to another); failed points marked ``x`` at the bottom of each panel."""
    plt = _pyplot()
    cols = {k: np.asarray(v) for k, v in table.items()}
    swept = [k for k in cols if k not in _SIM_RESULT_COLUMNS and not k.startswith(_SIM_RESULT_PREFIXES)]
    if not swept:
        raise InvalidInputError("the table has no swept parameter column", "table")
    xk, others = swept[0], swept[1:]
    x = cols[xk].astype(float)
    ok = np.isin(cols["status"].astype(str), ("final_time", "apex"))
    panels = [("apex height (m)", cols["apex_z_m"].astype(float))]
    if "end_x" in cols:
        panels.append(("end x (m)", cols["end_x"].astype(float)))
    panels.append(("impact losses (J)", cols["impact_loss_j"].astype(float)))
    fig, axes = plt.subplots(len(panels), 1, figsize=(7, 2.6 * len(panels)), sharex=True)
    keys = [tuple(str(cols[k][i]) for k in others) for i in range(len(x))]
    for ax, (label, y) in zip(axes, panels):
        for key in dict.fromkeys(keys):
            sel = np.array([k == key for k in keys]) & ok
            order = np.argsort(x[sel])
            name = ", ".join(f"{k}={v}" for k, v in zip(others, key)) or None
            ax.plot(x[sel][order], y[sel][order], marker="o", ms=3, label=name)
        if (~ok).any():
            lo = np.nanmin(y[ok]) if ok.any() and np.isfinite(y[ok]).any() else 0.0
            ax.plot(x[~ok], np.full(int((~ok).sum()), lo), "x", color="tab:red", label="failed")
        ax.set_ylabel(label)
        if others or (~ok).any():
            ax.legend(fontsize=7)
    axes[-1].set_xlabel(xk)
    fig.suptitle(title or f"sweep over {', '.join(swept)}", fontsize=10)
    fig.tight_layout()
    save_figure(fig, out_path)
    plt.close(fig)
    return os.fspath(out_path)
