"""``dsmv-predict task=exceedance`` answered by a fast model: a vehicle scene's P(sinkage > limit) beside
P(tilt > limit) and P(slide > limit), and one track's P(sinkage > limit) on a strength table.

The registered surrogates learn one track's sinkage on straight-line soils; a vehicle also tilts, by its
centre of gravity, its attitude at touchdown and how its two tracks bear. So a vehicle scene's samples (the
``uncertainty`` group's, as a track's) are each landed by the fast vehicle model
(:mod:`dsmv.analytic.vehicle`, docs/decisions/0033), all of a block at once. Per sample the answer
is what the verdict judges (:mod:`dsmv.safety`): the sinkage of the base's lowest point (the
grousers' tips), the largest tilt from level, the largest slide along the seabed (on a slope, or
drifting at touchdown), and whether the soil stopped the vehicle. A landing
the soil does not stop exceeds every limit.

One track on a strength table that is not one straight line (``soil.profile``) is landed by the fast
landing model (:func:`dsmv.analytic.landing_model.sinkage`, the 3D track's unless the scene names the
section's), the table at each sample's drawn level (``soil.profile_scale``).

The samples' E is their su0 times the scene's E/su0, as the surrogates' physics features hold it (on a
table, the table's own su0: its drawn level leaves E as it is, as ``soil.profile_scale`` does).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd

from dsmv.analytic.landing_model import Landing, default_config, sinkage
from dsmv.analytic.vehicle import STATUS, VehicleModel, vehicle_config
from dsmv.errors import ConfigError
from dsmv.surrogate.evaluate import pyplot
from dsmv.surrogate.fast_model import scene_settings, table_factor, table_landing

#: what may be uncertain for a vehicle: its load and touchdown, and the soil (its geometry is the scene's); on a
#: strength table, its level (soil.profile_scale) rather than su0 and ks, which the table sets
VEHICLE_UNCERTAIN = ("landing.mass_kg", "landing.inertial_mass_kg", "landing.velocity_m_s", "landing.gravity_m_s2",
                     "soil.su0_pa", "soil.ks_pa_per_m", "soil.sensitivity", "soil.xi95", "soil.rate.eta",
                     "soil.profile_scale")
#: a strength table's own: its mudline strength and first gradient
TABLE_SET = ("soil.su0_pa", "soil.ks_pa_per_m")
#: vehicles landed at once (a block of 1000 holds about 50 MB of patch arrays)
BLOCK = 1000


def check_uncertain(keys, table_soil: bool = False) -> None:
    """A vehicle's geometry is not drawn, nor a strength table's su0 and ks (its level is), nor a straight
    line's level: one line naming the key and what may be."""
    for key in keys:
        if key not in VEHICLE_UNCERTAIN:
            raise ConfigError(f"uncertainty.{key}", "a distribution", "a vehicle scene draws its load, touchdown and "
                              f"soil only: {', '.join(VEHICLE_UNCERTAIN)}")
        if table_soil and key in TABLE_SET:
            raise ConfigError(f"uncertainty.{key}", "a distribution", "the soil's strength is a table (soil.profile), "
                              "which sets su0 and ks: draw its level, soil.profile_scale (uncertainty=ccz_box_core "
                              f"draws it; or uncertainty.{key}=null)")
        if not table_soil and key == "soil.profile_scale":
            raise ConfigError(f"uncertainty.{key}", "a distribution", "scales a strength table (soil.profile); a "
                              "straight line su0 + ks·z draws soil.su0_pa and soil.ks_pa_per_m")


def fast_vehicle_config(scene):
    """The fast model's coefficients: the scene's own when it names the fast model (the 3D track's for the
    section's), else the 3D track's."""
    if scene.solver.name in ("analytic_dynamic", "analytic_dynamic_3d"):
        return vehicle_config(scene.solver)
    return default_config("analytic_dynamic_3d")


@dataclass(frozen=True)
class VehicleLandings:
    """The samples' landings by the fast vehicle model."""

    sinkage_m: np.ndarray   # the base's lowest point's deepest (m); inf where the soil did not stop it
    tilt_deg: np.ndarray    # the largest tilt from level (degrees)
    slide_m: np.ndarray     # the largest slide along the seabed (m)
    status: np.ndarray      # ok | bearing_failure | unstable
    seconds: float          # wall time of the landings (s)

    def exceeds(self, sinkage_limit_m: float, tilt_limit_deg: float | None,
                slide_limit_m: float | None = None) -> dict[str, np.ndarray]:
        """Per sample, which limits it breaks (a landing that did not end ``ok`` breaks them all)."""
        failed = self.status != "ok"
        out = {"sinkage": failed | (self.sinkage_m > sinkage_limit_m)}
        if tilt_limit_deg is not None:
            out["tilt"] = failed | (self.tilt_deg > tilt_limit_deg)
        if slide_limit_m is not None:
            out["slide"] = failed | (self.slide_m > slide_limit_m)
        return out


def drawn_landing(rows: pd.DataFrame, settings: dict, soil) -> Landing:
    """The rows (the scene with its uncertain columns drawn) as landings per track, on the scene's strength
    table, if it has one, at each row's drawn level."""
    tracks = replace(table_landing(rows, settings), strength=soil.bent_strength)
    if "profile_scale" in rows:  # the table's level drawn in place of the scene's: its strengths (E unscaled,
        scale = rows["profile_scale"].to_numpy(float) / soil.profile_scale  # as soil.profile_scale leaves it)
        tracks = replace(tracks, su0_pa=scale * tracks.su0_pa, ks_pa_per_m=scale * tracks.ks_pa_per_m,
                         strength_scale=scale)
    return tracks


def land_samples(scene, table: pd.DataFrame, progress=None) -> VehicleLandings:
    """Land each row of ``table`` (a dataset table: the scene with its uncertain columns drawn) with the
    fast vehicle model (a vehicle scene) or the fast landing model (one track: no tilt, no slide), in
    blocks of :data:`BLOCK`; ``progress(done, total, seconds)`` after each."""
    model = fast_vehicle_config(scene)
    settings = scene_settings(scene, model)
    deepest, tilt, slide = np.empty(len(table)), np.zeros(len(table)), np.zeros(len(table))
    status = np.empty(len(table), dtype=object)
    started = time.perf_counter()
    for first in range(0, len(table), BLOCK):
        rows = table.iloc[first:first + BLOCK].reset_index(drop=True)
        tracks, block = drawn_landing(rows, settings, scene.soil), slice(first, first + len(rows))
        if scene.geometry.vehicle:
            landed = VehicleModel(scene, model, table_factor(rows, settings, column=True), tracks,
                                  lambda index, rows=rows: table_factor(rows.iloc[index], settings, column=True)).land()
            ended = np.array([STATUS[int(code)] for code in landed["end"]], dtype=object)
            deepest[block] = np.where(ended == "bearing_failure", np.inf,
                                      np.maximum(landed["middle_m"], landed["edge_m"]))
            tilt[block], slide[block], status[block] = np.degrees(landed["turn_rad"]), landed["slide_m"], ended
        else:
            deepest[block] = sinkage(tracks, table_factor(rows, settings), model.coefficients(), model.bearing_factor,
                                     model.buoyancy)
            status[block] = np.where(np.isinf(deepest[block]), "bearing_failure", "ok")
        if progress is not None:
            progress(block.stop, len(table), time.perf_counter() - started)
    return VehicleLandings(deepest, tilt, slide, status, time.perf_counter() - started)


def probability(flags: np.ndarray) -> tuple[float, float]:
    """The fraction of samples flagged and its Monte Carlo standard error √(P(1 − P)/N)."""
    p = float(np.mean(flags))
    return p, math.sqrt(p * (1.0 - p) / len(flags))


def plot_vehicle_exceedance(landings: VehicleLandings, sinkage_limit_m: float, tilt_limit_deg: float | None,
                            path: Path, title: str) -> Path:
    """The samples' tilt against their sinkage, safe ones and those breaking a limit apart, the limits drawn."""
    plt = pyplot()
    flags = landings.exceeds(sinkage_limit_m, tilt_limit_deg)
    unsafe = np.any(np.stack(list(flags.values())), axis=0)
    stopped = np.isfinite(landings.sinkage_m)
    fig, ax = plt.subplots(figsize=(6.5, 4.6), constrained_layout=True)
    for chosen, colour, label in ((~unsafe & stopped, "tab:green", "within the limits"),
                                  (unsafe & stopped, "tab:red", "beyond a limit")):
        ax.scatter(landings.sinkage_m[chosen], landings.tilt_deg[chosen], s=4, alpha=0.4, color=colour,
                   label=f"{label} ({int(chosen.sum())})")
    ax.axvline(sinkage_limit_m, color="k", linestyle="--", label=f"sinkage limit {sinkage_limit_m:g} m")
    if tilt_limit_deg is not None:
        ax.axhline(tilt_limit_deg, color="k", linestyle=":", label=f"tilt limit {tilt_limit_deg:g}°")
    ax.set(xlabel="deepest sinkage of the base's lowest point (m)", ylabel="largest tilt from level (°)")
    not_stopped = int((~stopped).sum())
    ax.set_title(title + (f"\n{not_stopped} samples not stopped by the soil (not drawn)" if not_stopped else ""),
                 fontsize=9)
    ax.legend(fontsize=8)
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)
    return path


def plot_track_exceedance(landings: VehicleLandings, sinkage_limit_m: float, path: Path, title: str) -> Path:
    """The samples' sinkages as a histogram, the limit across it."""
    plt = pyplot()
    stopped = landings.sinkage_m[np.isfinite(landings.sinkage_m)]
    fig, ax = plt.subplots(figsize=(6.5, 4.2), constrained_layout=True)
    ax.hist(stopped, bins=60, color="tab:blue", alpha=0.7, label=f"samples stopped by the soil ({len(stopped)})")
    ax.axvline(sinkage_limit_m, color="k", linestyle="--", label=f"sinkage limit {sinkage_limit_m:g} m")
    ax.set(xlabel="sinkage at rest (m)", ylabel="samples")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=8)
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)
    return path


def landings_have_tips(scene) -> bool:
    """Whether the fast model lands the track's grousers' tips (the 3D track's) rather than a flat base."""
    return scene.geometry.kind == "track" and fast_vehicle_config(scene).grousers


def fast_model_exceedance(scene, table: pd.DataFrame, sinkage_limit_m: float, run_dir: Path | None, plot: bool,
                          prog: str) -> dict:
    """The answer to ``task=exceedance`` over the sampled ``table`` of a vehicle scene, or of one track on a
    strength table, by the fast model that lands it (:func:`land_samples`), printed; returns it."""
    vehicle = scene.geometry.vehicle
    tilt_limit, slide_limit = (scene.safety.max_tilt_deg, scene.safety.max_slide_m) if vehicle else (None, None)
    total, noun = len(table), "vehicles" if vehicle else "tracks"
    model = "fast vehicle model" if vehicle else "fast landing model"

    def progress(done: int, of: int, seconds: float) -> None:
        if of > BLOCK and seconds >= 1.0:  # a line per block of a landing that takes a while
            left = seconds / done * (of - done)
            print(f"{prog}: landed {done} of {of} {noun}, {seconds:.0f} s so far, about {left:.0f} s left",
                  flush=True)

    print(f"{prog}: the {model} " + ("(docs/decisions/0033)" if vehicle else "of the track (the surrogates learn "
          "straight-line soils; this one is a table)") + f" lands each of {total} samples", flush=True)
    landings = land_samples(scene, table, progress)
    print(f"  landed   : {total} {noun} in {landings.seconds:.1f} s "
          f"({1e3 * landings.seconds / total:.1f} ms each)")
    flags = landings.exceeds(sinkage_limit_m, tilt_limit, slide_limit)
    out = {"model": model, "samples": total, "sinkage_limit_m": sinkage_limit_m,
           "tilt_limit_deg": tilt_limit, "slide_limit_m": slide_limit, "landing_s": landings.seconds,
           "not_stopped": int((landings.status == "bearing_failure").sum()),
           "unsettled": int((landings.status == "unstable").sum())}
    p, error = probability(flags["sinkage"])
    print(f"  exceed   : P(sinkage > {sinkage_limit_m:g} m) = {p:.4f} ± {error:.4f} (Monte Carlo, {total} samples; "
          + ("the base's lowest point)" if vehicle else "the grousers' tips)" if landings_have_tips(scene) else
             "the base)"))
    out |= {"exceedance_probability": p, "monte_carlo_error": error}
    for what, limit, unit in (("tilt", tilt_limit, "°"), ("slide", slide_limit, " m")):
        if limit is not None:
            p_what, error_what = probability(flags[what])
            print(f"  {what:9s}: P({what} > {limit:g}{unit}) = {p_what:.4f} ± {error_what:.4f}")
            out |= {f"{what}_exceedance_probability": p_what, f"{what}_monte_carlo_error": error_what}
    if len(flags) > 1:
        p_any, error_any = probability(np.logical_or.reduce(list(flags.values())))
        print(f"  unsafe   : P(any limit) = {p_any:.4f} ± {error_any:.4f}")
        out |= {"unsafe_probability": p_any, "unsafe_monte_carlo_error": error_any}
    stopped = landings.tilt_deg[landings.status == "ok"]
    if vehicle and len(stopped):
        median, high = np.quantile(stopped, [0.5, 0.95])
        print(f"  tilts    : median {median:.3g}°, 95 % under {high:.3g}°"
              + ("" if tilt_limit is not None else " (set safety.max_tilt_deg for P(tilt > limit))"))
        out |= {"tilt_median_deg": float(median), "tilt_q95_deg": float(high)}
    if out["not_stopped"] or out["unsettled"]:
        print(f"warning: {out['not_stopped']} samples not stopped by the soil and {out['unsettled']} not settled "
              f"within the model's time: each counted beyond every limit")
    if plot and run_dir is not None:
        run_dir.mkdir(parents=True, exist_ok=True)
        title = (f"{model}, {total} samples: P(sinkage > {sinkage_limit_m:g} m) = {p:.3f}"
                 + (f", P(tilt > {tilt_limit:g}°) = {out['tilt_exceedance_probability']:.3f}" if tilt_limit else ""))
        path = run_dir / "exceedance.png"
        out["plot"] = str(plot_vehicle_exceedance(landings, sinkage_limit_m, tilt_limit, path, title) if vehicle
                          else plot_track_exceedance(landings, sinkage_limit_m, path, title))
        print(f"  plot     : {out['plot']}")
    return out
