"""Plots people would rather look at than read. matplotlib is imported lazily (Agg backend)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from dsmv.config.scene import SWEEP_PLOTS
from dsmv.post import studies
from dsmv.cel.fields import read_frame

HISTORY_PLOT_FILE = "history.png"


#: the resistance's smoothing window, as a fraction of the run's simulated duration
RESISTANCE_WINDOW_FRACTION = 0.05


def moving_mean(t: np.ndarray, values: np.ndarray, window: float) -> np.ndarray:
    """Each sample's mean over the samples within ±window/2 of its time (any spacing; NaN-free input)."""
    t, values = np.asarray(t, float), np.asarray(values, float)
    total = np.concatenate([[0.0], np.cumsum(values)])
    lo = np.searchsorted(t, t - 0.5 * window, side="left")
    hi = np.searchsorted(t, t + 0.5 * window, side="right")
    return (total[hi] - total[lo]) / np.maximum(hi - lo, 1)


def plot_history(history: dict[str, np.ndarray], path: Path, title: str) -> Path:
    """Sinkage against time and contact force against sinkage, side by side (PNG).

    The force is drawn raw (faint) and as its moving mean over a stated window: the explicit solver
    carries the soil's elastic waves, and the body's reaction, the sum of its nodes' contact forces,
    rings with them."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    time_s, sinkage = np.asarray(history["time_s"], float), np.asarray(history["sinkage_m"], float)
    force_kn = np.asarray(history["force_n"], float) / 1e3
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4.4), constrained_layout=True)
    left.plot(time_s, sinkage, color="tab:blue")
    left.set_xlabel("time (s)")
    left.set_ylabel("sinkage (m)")
    left.invert_yaxis()
    left.grid(alpha=0.3)
    right.plot(sinkage, force_kn, color="tab:red", alpha=0.3, linewidth=0.8, label="raw")
    finite = np.isfinite(force_kn) & np.isfinite(time_s)
    window = RESISTANCE_WINDOW_FRACTION * (time_s[finite].max() - time_s[finite].min()) if finite.sum() > 1 else 0.0
    if window > 0.0:
        smooth = moving_mean(time_s[finite], force_kn[finite], window)
        right.plot(sinkage[finite], smooth, color="tab:red", label=f"mean over {1e3 * window:.3g} ms")
        right.legend(fontsize=8, loc="best")
    right.set_xlabel("sinkage (m)")
    right.set_ylabel("soil resistance per track (kN)")
    right.grid(alpha=0.3)
    fig.suptitle(title, fontsize=10)
    fig.supxlabel("The raw resistance rings: the explicit solver carries the soil's elastic waves, and the body's "
                  "reaction sums them.", fontsize=7.5, color="0.35")
    fig.savefig(path, dpi=110, bbox_inches="tight")
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
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return Path(path)


_MAKERS = {
    "fall_cone": plot_fall_cone,
    "one_at_a_time": studies.one_at_a_time,
    "compare_analytic": studies.compare_analytic,
    "mesh_study": studies.mesh_study,
    "section_factors": studies.section_factors,
    "bearing_curves": studies.bearing_curves,
    "green_envelope": studies.green_envelope,
    "safe_region": studies.safe_region,
    "vehicle_response": studies.vehicle_response,
    "per_vehicle": studies.per_vehicle,
}
#: what draws each sweep-level plot an experiment can ask for (``sweep_plot: <name>``, one of
#: :data:`dsmv.config.scene.SWEEP_PLOTS`): ``maker(sweep_dir, png_path)``
SWEEP_PLOT_MAKERS = {name: _MAKERS[name] for name in SWEEP_PLOTS}


FIELD_PLOT_FILE = "fields_max_sinkage.png"
#: the soil is drawn where its volume fraction is at least this: the interface as the
#: half-full level, as volume-of-fluid methods place it (Hirt & Nichols 1981)
SOIL_LEVEL = 0.5
#: colour bands per map, like the banded contour plots of Abaqus in the reference study
CONTOUR_BANDS = 12
#: velocity arrows across the window's width
ARROWS_ACROSS = 24
#: the strength panel's note: at the deepest frame the body is at rest but the soil around it still
#: shears, and a law with a rate effect (Einav–Randolph's R(γ̇) = 1 + η·(γ̇/γ̇ref)^n) keeps su above
#: the intact strength there; Tresca's su is su_intact
SU_NOTE = "su above su_intact = su0 + ks·z is the rate effect: Einav–Randolph's R(γ̇) > 1 where the soil shears"


def is_whole_section(frame) -> bool:
    """Whether a 2D frame holds the whole section (its grid spans both sides of the axis x = 0)."""
    return frame.x[0] < 0.0


def _mirrored_view(frame, window):
    """The half model mirrored about the symmetry axis x = 0 (the whole section as it is), ready to
    draw in ``window``.

    Returns a dict: node coordinates x, y; cell fields; cell velocity (ux, uy), the mean of a
    cell's four nodal velocities (m/s); ``shown``, the soil cells inside the window.
    """
    half_width, bottom, top = window
    vx, vy = frame.velocity[..., 0], frame.velocity[..., 1]
    if is_whole_section(frame):
        x, cells = frame.x, dict(frame.cells)
    else:
        x = np.concatenate([-frame.x[:0:-1], frame.x])
        cells = {k: np.concatenate([v[::-1], v]) for k, v in frame.cells.items()}
        vx, vy = np.concatenate([-vx[:0:-1], vx]), np.concatenate([vy[:0:-1], vy])
    ux, uy = (0.25 * (v[:-1, :-1] + v[1:, :-1] + v[1:, 1:] + v[:-1, 1:]) for v in (vx, vy))
    xc, yc = 0.5 * (x[1:] + x[:-1]), 0.5 * (frame.y[1:] + frame.y[:-1])
    inside = (np.abs(xc)[:, None] <= half_width) & (yc[None, :] >= bottom) & (yc[None, :] <= top)
    shown = (cells["volume_fraction"] >= SOIL_LEVEL) & inside & np.isfinite(cells["su_pa"])
    return dict(x=x, y=frame.y, xc=xc, yc=yc, cells=cells, ux=ux, uy=uy, shown=shown, n_half=(len(x) - 1) // 2)


def _core_window(frame):
    """The grid's uniform core (where the solver expects the soil to deform), capped just above the soil (m)."""
    x = frame.x[frame.x >= 0.0] if is_whole_section(frame) else frame.x  # the half beside the axis
    dx, dy = np.diff(x), np.diff(frame.y)
    # the core's cell size: the one most cells across have (a graded axis may close with a smaller cell,
    # a vehicle's axis opens with one at its middle plane)
    sizes, counts = np.unique(np.round(dx, 12), return_counts=True)
    h = sizes[counts.argmax()]
    core_x = np.nonzero(np.isclose(dx, h, rtol=1e-6))[0]
    core_y = np.nonzero(np.isclose(dy, h, rtol=1e-6))[0]
    soil_rows = np.nonzero((frame.cells["volume_fraction"] >= SOIL_LEVEL).any(axis=0))[0]
    top = frame.y[soil_rows.max() + 1] if soil_rows.size else frame.y[core_y.max() + 1]
    bottom = frame.y[core_y.min()]
    top = min(top + 0.15 * (top - bottom), frame.y[core_y.max() + 1])
    return x[core_x.max() + 1], bottom, top


def _contour_panel(fig, ax, view, values, label, cmap, title, window, arrows=False):
    """One banded map of ``values`` over the soil of ``view``, the body in grey, optional velocity arrows."""
    import matplotlib.pyplot as plt
    from matplotlib.colors import BoundaryNorm, ListedColormap
    from matplotlib.ticker import MaxNLocator

    half_width, bottom, top = window
    data = np.ma.masked_where(~view["shown"], values)
    lo, hi = (float(data.min()), float(data.max())) if data.count() else (0.0, 1.0)
    levels = MaxNLocator(nbins=CONTOUR_BANDS).tick_values(lo, hi if hi > lo else lo + 1e-12)
    colours = plt.get_cmap(cmap)
    mesh = ax.pcolormesh(view["x"], view["y"], data.T, cmap=colours, norm=BoundaryNorm(levels, colours.N))
    body = view["cells"]["body"]
    ax.pcolormesh(view["x"], view["y"], np.ma.masked_where(body < 0.5, body).T, cmap=ListedColormap(["0.6"]),
                  vmin=0, vmax=1)
    fig.colorbar(mesh, ax=ax, label=label, shrink=0.9)
    if arrows:  # on every few cells, the same columns on both sides of the axis
        step = max(1, int(round(2 * half_width / np.diff(view["x"]).min() / ARROWS_ACROSS)))
        n_half = view["n_half"]
        columns = np.arange(step // 2, n_half, step)
        pick = np.zeros_like(view["shown"])
        pick[np.concatenate([n_half - 1 - columns, n_half + columns]), step // 2 :: step] = True
        ii, jj = np.nonzero(pick & view["shown"])
        speed = np.hypot(view["ux"][ii, jj], view["uy"][ii, jj])
        top_speed = float(speed.max()) if speed.size and np.isfinite(speed).all() and speed.max() > 0 else 1.0
        # the fastest arrow spans 90 % of the arrow spacing: no arrow runs over its neighbours
        ax.quiver(view["xc"][ii], view["yc"][jj], view["ux"][ii, jj], view["uy"][ii, jj], color="white",
                  width=0.0025, angles="xy", scale_units="xy",
                  scale=top_speed / (0.9 * step * np.diff(view["x"]).min()))
    ax.set_title(title, fontsize=9)
    ax.set_xlim(-half_width, half_width)
    ax.set_ylim(bottom, top)
    ax.set_aspect("equal")


def plot_field_contours(frame_path: Path, path: Path, title: str, flow_frame_path: Path | None = None) -> list[Path]:
    """Banded contours of su, ξ, the shear strain rate and the soil velocity around the body at one
    field frame.

    Like the reference study's Figures 3 and 10 (strength), 8 (accumulated plastic shear
    strain) and 12 (velocity). The half model is mirrored to show the whole section; only
    soil is coloured (volume fraction ≥ SOIL_LEVEL), the body is grey, the window is the
    grid's uniform core. Velocity: the mean of a cell's four nodal velocities, with arrows. The
    strength panel notes (:data:`SU_NOTE`) that su above the intact strength is the rate effect.
    ``flow_frame_path``: a frame whose velocity field is shown too, in the same window (at
    the deepest point a landing body is at rest and the soil's velocity is what rings on;
    the mechanism shows while it still moves). Reads VTU frames written by :mod:`dsmv.cel.fields`.

    A 3D frame is drawn on its symmetry planes: the cross-section (x, z) at ``path`` and, for a
    plate, the longitudinal section (y, z) beside it (:data:`LONGITUDINAL_SUFFIX`). Returns the
    figures written.
    """
    frame = read_frame(frame_path)
    flow = [] if flow_frame_path is None else [read_frame(flow_frame_path)]
    if frame.z is None:
        return [_plot_section(frame, flow, path, title)]
    path = Path(path)
    written = [_plot_section(frame.section("y"), [f.section("y") for f in flow], path, f"{title}: cross-section y = 0")]
    if len(frame.y) > 2:  # a plate (a strip's slab is one cell thick: its section is the cross-section)
        longitudinal = path.with_name(path.stem + LONGITUDINAL_SUFFIX + path.suffix)
        written.append(_plot_section(frame.section("x"), [f.section("x") for f in flow], longitudinal,
                                     f"{title}: longitudinal section x = 0"))
    return written


#: a 3D run's longitudinal section is drawn beside its cross-section, the file name's stem + this
LONGITUDINAL_SUFFIX = "_longitudinal"


def _plot_section(frame, flow: list, path: Path, title: str) -> Path:
    """The contour panels of one 2D frame (or a 3D frame's section) and its flow frames."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    window = _core_window(frame)
    half_width, bottom, top = window
    # panels 8 in wide at the window's aspect, kept between 2.2 and 5 in high (inches, matplotlib's unit)
    panel_height = min(max(2.2, 3.5 * (top - bottom) / half_width), 5.0)
    fig, axes = plt.subplots(4 + len(flow), 1, constrained_layout=True, figsize=(8, (4 + len(flow)) * panel_height + 1))
    view = _mirrored_view(frame, window)
    when = f"t = {frame.time_s:.4f} s, sinkage {frame.sinkage_m:.4f} m"
    _contour_panel(fig, axes[0], view, view["cells"]["su_pa"] / 1e3, "su (kPa)", "viridis",
                   f"undrained strength su, {when}\n{SU_NOTE}", window)
    _contour_panel(fig, axes[1], view, view["cells"]["plastic_shear_strain"], "ξ (-)", "inferno",
                   f"accumulated plastic shear strain ξ, {when}", window)
    # the strain rate spans decades (the study's rate law reads its logarithm): log10, floored at 10⁻³ 1/s;
    # drawn while the soil still flows (the flow frame's), as at rest only the ringing is left
    moving = (flow or [frame])[0]
    rate_view = _mirrored_view(moving, window)
    rate = np.log10(np.maximum(rate_view["cells"]["shear_strain_rate_per_s"], 1e-3))
    _contour_panel(fig, axes[2], rate_view, rate, "log10 γ̇ (1/s)", "magma",
                   f"shear strain rate γ̇, t = {moving.time_s:.4f} s, sinkage {moving.sinkage_m:.4f} m", window)
    for ax, one in zip(axes[3:], [frame, *flow]):
        view = _mirrored_view(one, window)
        _contour_panel(fig, ax, view, np.hypot(view["ux"], view["uy"]), "|v| (m/s)", "plasma",
                       f"soil velocity, t = {one.time_s:.4f} s, sinkage {one.sinkage_m:.4f} m", window, arrows=True)
    across, up = frame.labels
    for ax in axes:
        ax.set_ylabel(f"{up} (m)")
    axes[-1].set_xlabel(f"{across} (m): 0 on the body's axis; {up} = 0 the body's base at touchdown")
    fig.suptitle(title, fontsize=10)
    fig.savefig(path, dpi=110, bbox_inches="tight")  # a tall equal-aspect panel's label is kept
    plt.close(fig)
    return Path(path)
