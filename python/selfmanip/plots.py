"""PNG plots of leaps and sweeps (matplotlib, imported lazily with the ``Agg`` backend;
install the ``plot`` extra):

* :func:`sweep_figure` — thesis Figs. 3.4/3.5 style: apex height, forward displacement and
  pitch against ``t2`` for each strategy (one line per gear ratio), each point coloured by its
  leap word; against the gear ratio instead when a sweep has a single ``t2``;
* :func:`leap_strip` — a keyframe strip in the style of Fig. 5.1: the body, the legs and the
  contact forces (ground on robot, arrows) at evenly spaced times.

:func:`plot_file` dispatches on the file: a sweep table (``.csv``/``.parquet``), a leap
(``.json`` from ``selfmanip leap --json``) or an MCAP log (``.mcap``).
"""

from __future__ import annotations

import json
import math
import os
from typing import Any, Mapping

import numpy as np

from .leap import LeapResult, Trajectory

__all__ = ["sweep_figure", "leap_strip", "plot_file", "load_leap"]

#: Length of a force arrow (m per N) in :func:`leap_strip`.
FORCE_SCALE_M_PER_N = 0.004


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def sweep_figure(table: Mapping[str, Any], out_path: str | os.PathLike, title: str | None = None) -> str:
    """Draws a sweep table (a dict of columns or a pandas DataFrame) and returns the path."""
    plt = _pyplot()
    cols = {k: np.asarray(table[k]) for k in table.keys()}
    for need in ("strategy", "t2_s", "gear_ratio", "apex_z_m", "apex_x_m", "apex_phi_rad", "word", "status"):
        if need not in cols:
            raise ValueError(f"sweep table has no `{need}` column")
    strategies = [s for s in ("++", "+-", "-+", "--") if s in set(cols["strategy"].astype(str))]
    strategies += sorted(set(cols["strategy"].astype(str)) - set(strategies))
    t2_values = np.unique(cols["t2_s"])
    gears = cols["gear_ratio"].astype(float)
    by_gear = len(t2_values) == 1 and len(np.unique(gears[~np.isnan(gears)])) > 1
    xkey, xlabel = ("gear_ratio", "gear ratio G") if by_gear else ("t2_s", "t2 (s)")
    lines_key = "t2_s" if by_gear else "gear_ratio"
    panels = [("apex_z_m", "apex height (m)"), ("apex_x_m", "displacement (m)"),
              ("apex_xdot_m_s", "forward speed at apex (m/s)") if by_gear else ("apex_phi_rad", "pitch at apex (rad)")]
    ok_rows = cols["status"].astype(str) == "ok"
    words = [w for w in dict.fromkeys(cols["word"].astype(str)[ok_rows]) if w]
    cmap = plt.get_cmap("tab10" if len(words) <= 10 else "tab20")
    colour = {w: cmap(i % cmap.N) for i, w in enumerate(words)}
    fig, axes = plt.subplots(len(strategies), 3, figsize=(13, 2.8 * len(strategies) + 1.2), squeeze=False,
                             sharex=True)
    for i, s in enumerate(strategies):
        sel = cols["strategy"].astype(str) == s
        for j, (key, label) in enumerate(panels):
            ax = axes[i, j]
            if key not in cols:
                ax.set_visible(False)
                continue
            for line in np.unique(cols[lines_key][sel]):
                lk = cols[lines_key].astype(float)
                m = sel & (np.isnan(lk) if math.isnan(float(line)) else lk == line)
                order = np.argsort(cols[xkey][m])
                x, y = cols[xkey][m][order], cols[key][m][order].astype(float)
                ax.plot(x, y, "-", color="0.7", lw=0.8, zorder=1)
                w = cols["word"][m][order].astype(str)
                ok = cols["status"][m][order].astype(str) == "ok"
                for word in dict.fromkeys(w):
                    k = (w == word) & ok & np.isfinite(y)
                    if k.any():
                        ax.scatter(x[k], y[k], s=14, color=colour.get(word, "k"), zorder=2)
                bad = ~ok
                if bad.any():
                    lo = np.nanmin(y) if np.isfinite(y).any() else 0.0
                    ax.scatter(x[bad], np.full(bad.sum(), lo), marker="x", s=12, color="0.4", zorder=2)
            ax.set_ylabel(label)
            if j == 0:
                ax.set_title(f"strategy ({s[0]}, {s[1]})", loc="left", fontsize=10)
            if i == len(strategies) - 1:
                ax.set_xlabel(xlabel)
    handles = [plt.Line2D([], [], marker="o", ls="", color=colour[w], label=w) for w in words]
    handles.append(plt.Line2D([], [], marker="x", ls="", color="0.4", label="no apex (status not ok)"))
    fig.legend(handles=handles, loc="lower center", ncol=min(3, len(handles)), fontsize=8, title="leap word")
    fig.suptitle(title or "Leap sweep: apex height, displacement and pitch (cf. thesis Figs. 3.4-3.5)")
    fig.tight_layout(rect=(0, 0.03 + 0.025 * math.ceil(len(handles) / 3), 1, 0.97))
    fig.savefig(out_path, dpi=110)
    plt.close(fig)
    return os.fspath(out_path)


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
        raise ValueError("the trajectory has no samples")
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
    fig.savefig(out_path, dpi=110)
    plt.close(fig)
    return os.fspath(out_path)


def load_leap(path: str | os.PathLike) -> tuple[dict[str, Any], Trajectory, dict[str, Any]]:
    """``(params, trajectory, info)`` from a leap JSON (``selfmanip leap --json``) or MCAP log."""
    p = os.fspath(path)
    if p.endswith(".json"):
        with open(p, encoding="utf-8") as fh:
            d = json.load(fh)
        if not d.get("trajectory"):
            raise ValueError(f"{p}: the leap has no trajectory")
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
        if "params" not in meta:
            raise ValueError(f"{p}: no selfmanip metadata with the parameters")
        traj = Trajectory(t_s=np.asarray(t), q=np.asarray(q), qd=np.asarray(qd), mode=mode, contacts=contacts,
                          contact_points_m=np.asarray(pts, dtype=float), contact_forces_n=np.asarray(frc, dtype=float))
        info = {k: meta.get(k) for k in ("strategy", "t2_s", "gear_ratio", "word", "status")}
        info["config"] = json.loads(meta["config"]) if "config" in meta else None
        return json.loads(meta["params"]), traj, info
    raise ValueError(f"{p}: expected a .json or .mcap leap")


def plot_result(result: LeapResult, out_path: str | os.PathLike, n_frames: int = 6) -> str:
    """:func:`leap_strip` of a :class:`selfmanip.leap.LeapResult`."""
    if result.trajectory is None:
        raise ValueError("this result has no trajectory: run leap(..., dt=...)")
    return leap_strip(result.params, result.trajectory, out_path, n_frames,
                      title=f"leap {result.strategy} t2={result.t2_s:g} s: {result.word} ({result.status})",
                      terrain=result.config.get("terrain"))


def plot_file(path: str | os.PathLike, out_path: str | os.PathLike) -> str:
    """A sweep table (.csv/.parquet) → :func:`sweep_figure`; a leap (.json/.mcap) →
    :func:`leap_strip`."""
    p = os.fspath(path)
    if not os.path.exists(p):
        raise ValueError(f"no such file: {p}")
    if p.endswith((".csv", ".parquet")):
        from .cli_leap import read_table

        return sweep_figure(read_table(p), out_path)
    params, traj, info = load_leap(p)
    title = None
    if info.get("strategy"):
        title = f"leap {info['strategy']} t2={info.get('t2_s')} s: {info.get('word')} ({info.get('status')})"
    cfg = info.get("config") or {}
    return leap_strip(params, traj, out_path, title=title, terrain=cfg.get("terrain"))
