"""A picture of a replay: logged against simulated reference-point paths (``drx sim replay --png``)."""

from __future__ import annotations

import math
from pathlib import Path

from drx.calibration.replay import ReplayResult


def draw_replay(result: ReplayResult, path: Path) -> Path:
    """Draw the kept windows' paths (one panel each, logged black, drx orange) and the error
    distribution; returns ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    paths = result.paths
    cols = 4
    rows = max(1, math.ceil(len(paths) / cols)) + 1
    fig = plt.figure(figsize=(3.2 * cols, 3.0 * rows), dpi=100)
    for i, (logged, simulated) in enumerate(paths):
        ax = fig.add_subplot(rows, cols, i + 1)
        ax.plot(logged[:, 0], logged[:, 1], "-o", color="black", ms=2, lw=1.2, label="DeepRacer log")
        ax.plot(simulated[:, 0], simulated[:, 1], "-o", color="tab:orange", ms=2, lw=1.2, label="drx")
        ax.plot(logged[0, 0], logged[0, 1], "s", color="tab:green", ms=5)
        err = math.hypot(*(simulated[-1] - logged[-1]))
        ax.set_title(f"window {i + 1}: {100 * err:.0f} cm apart", fontsize=9)
        ax.set_aspect("equal", adjustable="datalim")
        ax.tick_params(labelsize=7)
        if i == 0:
            ax.legend(fontsize=7, loc="best")
    ax = fig.add_subplot(rows, 1, rows)
    err_cm = 100 * result.position_error
    base_cm = 100 * result.baseline_error
    bins = np.linspace(0, max(float(np.percentile(base_cm, 98)), 1.0), 60).tolist()
    base_label = f"extrapolation (median {np.median(base_cm):.0f} cm)"
    ax.hist(base_cm, bins=bins, color="grey", alpha=0.5, label=base_label)
    drx_label = f"drx (median {np.median(err_cm):.0f} cm)"
    ax.hist(err_cm, bins=bins, color="tab:orange", alpha=0.7, label=drx_label)
    ax.set_xlabel(f"reference point distance from the log after {result.horizon} steps [cm]")
    ax.set_ylabel("windows")
    ax.legend(fontsize=8)
    fig.suptitle(f"Open-loop replay of {len(result)} logged windows", fontsize=11)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
    return path
