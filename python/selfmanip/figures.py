"""PNG plots of thesis Figs. 4.3, 4.6, 4.8, 4.10-4.12 from the analyses (matplotlib, imported
lazily with the ``Agg`` backend; install the ``plot`` extra). :func:`figure_data` returns the
numbers behind each figure; :func:`plot_figure` draws one."""

from __future__ import annotations

import math
import os
from typing import Any

import numpy as np

from . import analysis
from .errors import InvalidInputError, InvalidTypeError

FIGURE_NAMES = ("fig4.3", "fig4.6", "fig4.8", "fig4.10", "fig4.11", "fig4.12")
_DEG = 180.0 / math.pi


def _check(name: Any) -> str:
    if not isinstance(name, str):
        raise InvalidTypeError(f"`name` must be a string, got {type(name).__name__}", "name")
    if name not in FIGURE_NAMES:
        raise InvalidInputError(f"unknown figure {name!r} (known: {', '.join(FIGURE_NAMES)})", "name")
    return name


def figure_data(name: str, n: int | None = None) -> dict[str, np.ndarray]:
    """The data behind a figure as named 1-D or 2-D arrays (radians, m/s, rad/s)."""
    from .rhex import Model

    name = _check(name)
    if name in ("fig4.3", "fig4.6"):
        m = Model().contact_mode_map(96 if n is None else n)
        return {"theta1": m.theta1, "theta2": m.theta2, "phi": m.phi, "height_m": m.height_m,
                "front": m.front, "rear": m.rear, "label": m.label}
    if name == "fig4.8":
        return analysis.fig_4_8(25 if n is None else n)
    if name == "fig4.10":
        return analysis.fig_4_10(13 if n is None else n)
    if name == "fig4.11":
        return analysis.fig_4_11()
    return analysis.fig_4_12()


def plot_figure(name: str, out_path: str | os.PathLike, n: int | None = None) -> str:
    """Draws figure ``name`` (one of :data:`FIGURE_NAMES`) to a PNG at ``out_path``."""
    name = _check(name)
    out = os.fspath(out_path)
    from .plots import _pyplot

    plt = _pyplot()
    d = figure_data(name, n)
    fig, axes = plt.subplots(1, 2 if name == "fig4.10" else 1, figsize=(9 if name == "fig4.10" else 6, 4.5))
    axes = np.atleast_1d(axes)
    ax = axes[0]
    if name == "fig4.3":
        pairs = sorted({f"{f}{r}" for f, r in zip(d["front"].ravel(), d["rear"].ravel()) if f})
        code = np.full(d["phi"].shape, np.nan)
        for k, pr in enumerate(pairs):
            code[(np.char.add(d["front"].astype(str), d["rear"].astype(str))) == pr] = k
        im = ax.pcolormesh(d["theta1"] * _DEG, d["theta2"] * _DEG, code, cmap="tab10", shading="auto")
        cb = fig.colorbar(im, ax=ax, ticks=range(len(pairs)))
        cb.ax.set_yticklabels(pairs)
        ax.set_title("Fig. 4.3: quasi-static supports (front, rear)")
    elif name == "fig4.6":
        cs = ax.contourf(d["theta1"] * _DEG, d["theta2"] * _DEG, d["phi"] * _DEG, levels=24, cmap="RdBu_r")
        fig.colorbar(cs, ax=ax, label="pitch phi (deg)")
        ax.set_title("Fig. 4.6: quasi-static pitch")
    elif name == "fig4.8":
        sc = ax.scatter(d["theta1"] * _DEG, d["theta2"] * _DEG, c=d["max_leg_speed"] * _DEG, cmap="viridis", s=18)
        fig.colorbar(sc, ax=ax, label="leg speed at takeoff (deg/s)")
        ax.set_title("Fig. 4.8: leg speed before a contact lifts")
    elif name == "fig4.10":
        for a, key in zip(axes, ("stick", "rolling")):
            cs = a.contourf(d["theta2"] * _DEG, d["phi"] * _DEG, d[key].T, levels=16)
            fig.colorbar(cs, ax=a, label="|x_dot| (m/s)")
            a.set_title(f"Fig. 4.10: {key} leg, G = 23")
            a.set_xlabel("theta2 (deg)")
            a.set_ylabel("phi (deg)")
    elif name == "fig4.11":
        for j, phi in enumerate(d["phi"]):
            ax.plot(d["gear_ratio"], d["xdot"][:, j], label=f"phi = {phi * _DEG:.0f} deg")
        ax.axvline(23.0, color="k", ls="--", lw=0.8, label="X-RHex (23)")
        ax.set_xlabel("gear ratio G")
        ax.set_ylabel("best |x_dot| at takeoff (m/s)")
        ax.legend(fontsize=7)
        ax.set_title("Fig. 4.11: takeoff speed vs gear ratio (rolling leg)")
    else:
        cs = ax.contourf(d["phidot"] * _DEG, d["phi"] * _DEG, d["xdot"].T, levels=16)
        fig.colorbar(cs, ax=ax, label="best |x_dot| (m/s)")
        ax.set_xlabel("phi_dot (deg/s)")
        ax.set_ylabel("phi (deg)")
        ax.set_title("Fig. 4.12: takeoff speed vs pitch rate, G = 23")
    if name in ("fig4.3", "fig4.6", "fig4.8"):
        ax.set_xlabel("theta1 (deg)")
        ax.set_ylabel("theta2 (deg)")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out
