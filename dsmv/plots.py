"""Plots people would rather look at than read. matplotlib is imported lazily (Agg backend)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

HISTORY_PLOT_FILE = "history.png"


def plot_history(history: dict[str, np.ndarray], path: Path, title: str) -> Path:
    """Sinkage against time and contact force against sinkage, side by side (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    left.plot(history["time_s"], history["sinkage_m"], color="tab:blue")
    left.set_xlabel("time (s)")
    left.set_ylabel("sinkage (m)")
    left.invert_yaxis()
    left.grid(alpha=0.3)
    right.plot(history["sinkage_m"], np.asarray(history["force_n"]) / 1e3, color="tab:red")
    right.set_xlabel("sinkage (m)")
    right.set_ylabel("soil resistance per track (kN)")
    right.grid(alpha=0.3)
    fig.suptitle(title, fontsize=10)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)
