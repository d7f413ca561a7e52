"""Plots people would rather look at than read. matplotlib is imported lazily (Agg backend)."""

from __future__ import annotations

import math
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


def plot_fall_cone(sweep_dir: Path, path: Path) -> Path | None:
    """Simulated fall-cone depth against Hansbo's d = √(K·m·g/su), K = 0.8 (the study's Figure 4).

    One marker per job (soil × law); the band between K = 0.5 and 1.33 is the range published
    for 30° cones. Reads each job's result.json and resolved config under ``sweep_dir``.
    """
    import json

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from omegaconf import OmegaConf

    points = []
    for result_file in sorted(Path(sweep_dir).glob("*/result.json")):
        result = json.loads(result_file.read_text())
        if result["status"] != "ok" or "max_sinkage_m" not in result["metrics"]:
            continue
        cfg = OmegaConf.load(result_file.parent / "config_resolved.yaml")
        g = cfg.landing.gravity_m_s2
        hansbo = math.sqrt(0.8 * cfg.landing.mass_kg * g / cfg.soil.su0_pa)
        points.append((cfg.soil.name, result["soil_law"], hansbo, result["metrics"]["max_sinkage_m"]))
    if not points:
        return None
    fig, ax = plt.subplots(figsize=(5.5, 5), constrained_layout=True)
    top = 1.3 * max(max(p[2], p[3]) for p in points) * 1e3
    d = np.linspace(0, top, 50)
    ax.plot(d, d, color="k", lw=1, label="Hansbo, K = 0.8")
    ax.fill_between(d, d * math.sqrt(0.5 / 0.8), d * math.sqrt(1.33 / 0.8), color="0.85",
                    label="K = 0.5 – 1.33 (30° cones)")
    markers = {"tresca": "o", "einav_randolph": "s"}  # the law by its marker, the soil by its colour
    soils = sorted({p[0] for p in points})
    colours = {soil: plt.cm.tab10(k % 10) for k, soil in enumerate(soils)}
    for soil, law, hansbo, depth in points:
        ax.plot(hansbo * 1e3, depth * 1e3, markers.get(law, "^"), color=colours[soil], ms=7, label=f"{soil}, {law}")
    ax.set_xlabel("Hansbo depth √(0.8·m·g/su) (mm)")
    ax.set_ylabel("simulated depth (mm)")
    ax.set_xlim(0, top)
    ax.set_ylim(0, top)
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)


#: sweep-level plots an experiment can ask for with ``sweep_plot: <name>``
SWEEP_PLOTS = {"fall_cone": plot_fall_cone}
