"""The site tests run on dsmv's CEL: a T-bar pushed at a rate, a cyclic T-bar, a fall cone.

Two users: ``dsmv-calibrate``'s CEL check at the best fit (:func:`dsmv.calibration.run.cel_check`), and
a synthetic site measured on the CEL at known soil values, the data a calibration must recover when
the truth is not its own fast models' (``python -m dsmv.calibration.cel_site``).

The bar runs at :data:`SPEED_DIAMETERS_PER_S` with γ̇ref scaled alike (Einav–Randolph only; another
law runs at the test's own speed).
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from dsmv.calibration.data import SiteTest
from dsmv.config.profile import read_points

#: the bar's speed in the CEL, diameters a second: an explicit run's steps grow with the time pushed (a
#: 40 mm bar at 20 mm/s through 2 D: 530,000 steps on D/10). The law sees the same γ̇/γ̇ref when γ̇ref is
#: scaled with the speed (an exact similarity of the Einav–Randolph law's rate forms), and the soil's
#: inertia stays small: ρ'·v²/su = 0.002 for a 40 mm bar in 5 kPa clay
SPEED_DIAMETERS_PER_S = 2.5
#: the push before a resistance is read (diameters): a bar wished in place into softening soil reaches
#: its steady resistance as the soil it has remoulded flows round it; dsmv's CEL T-bar held steady to
#: 0.3 % over the last diameter of 4 to 8 (St 2–5, ξ95 10–30)
STEADY_TRAVEL_DIAMETERS = 6.0
#: the cyclic push's stroke (diameters): the soil at mid-stroke is passed in full by each stroke
STROKE_DIAMETERS = 4.0
#: the shallowest start of the bar's axis (diameters): the bar starts wished in place, buried. From 1.5 D a
#: rough bar on D/10 in soil of St 4 dragged its cover down and kept it: slip in one softened column of cells
#: at its shoulder, a trench above, the soil never closing behind it, 21 % under full flow down to 0.6 m at
#: 0.2 mm/s, where the rate's weak brake never broke the band (at 2 mm/s it broke within 3 D; at 20 mm/s it
#: did not hold). Started at 2.5 D the same push reads full flow (−0.4 % against the model)
SHALLOWEST_AXIS_DIAMETERS = 2.5
#: the fall cone's length (m): GEONOR's 30° cone, 35 mm long (conf/geometry/fall_cone_30deg.yaml)
CONE_LENGTH_M = 0.035


def soil_overrides(soil) -> list[str]:
    """The soil as command-line overrides: its law's values, density and elasticity, and its table."""
    flat = {"soil.law": soil.law, "soil.su0_pa": soil.su0_pa, "soil.ks_pa_per_m": soil.ks_pa_per_m,
            "soil.sensitivity": soil.sensitivity, "soil.xi95": soil.xi95, "soil.rate.law": soil.rate.law,
            "soil.rate.eta": soil.rate.eta, "soil.rate.n": soil.rate.n, "soil.rate.gamma_dot_ref": soil.rate.gamma_dot_ref,
            "soil.rate.mu": soil.rate.mu, "soil.density_kg_m3": soil.density_kg_m3,
            "soil.youngs_modulus_pa": soil.youngs_modulus_pa, "soil.poisson_ratio": soil.poisson_ratio}
    # a table (its own strengths, at the fitted level) in Hydra's list syntax
    table = ([f"soil.profile=[{','.join(f'[{float(d)!r},{float(su)!r}]' for d, su in read_points(soil.profile))}]",
              f"soil.profile_scale={float(soil.profile_scale)!r}"] if soil.profile is not None else [])
    return [*(f"{k}={v}" if isinstance(v, str) else f"{k}={float(v)!r}" for k, v in flat.items()), *table]


def tbar_overrides(soil, diameter_m: float, velocity: float, axis_depth: float, travel: float, cells: int) -> list[str]:
    """The T-bar push: the soil, the bar's size and speed, its axis's start, D/cells cells."""
    D = diameter_m
    return ["geometry=tbar", "landing=push", "solver=cel2d", f"geometry.width_m={float(D)!r}",
            f"landing.velocity_m_s={float(velocity)!r}", f"landing.displacement_m={float(travel)!r}",
            f"landing.initial_depth_m={float(axis_depth + D / 2.0)!r}", f"mesh.cell_size_m={float(D / cells)!r}",
            "solver.contact_separation=false", "output.plots=false", *soil_overrides(soil)]


def _solve(overrides: list[str], folder: Path):
    from dsmv import registry
    from dsmv.config.tree import compose_scene

    scene = compose_scene(overrides)
    folder.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    result = registry.load("solvers", scene.solver.name, "solver.name")(scene).solve(folder)
    if result.status == "interrupted":  # a signal stopped the run: it stops what runs it too
        raise KeyboardInterrupt(f"{result.message} ({folder})")
    return scene, result, time.perf_counter() - started


class TbarPush:
    """One CEL T-bar push (optionally cyclic): its run and, if it ended ``ok``, the bar's axis and net
    resistance (Pa) along its history, and each sample's stroke (0: first down, 1: up, 2: down, …)."""

    def __init__(self, soil, diameter_m: float, velocity: float, start_axis_m: float, travel_m: float, cells: int,
                 folder: Path, cycles: int = 0, stroke_m: float | None = None, extra: tuple[str, ...] = ()):
        D = self.diameter_m = float(diameter_m)
        self.velocity_m_s = float(velocity)
        speed = SPEED_DIAMETERS_PER_S * D if soil.law == "einav_randolph" else float(velocity)
        run_soil = soil.model_copy(update={"rate": soil.rate.model_copy(
            update={"gamma_dot_ref": soil.rate.gamma_dot_ref * speed / velocity})})
        overrides = tbar_overrides(run_soil, D, speed, start_axis_m, travel_m, cells)
        if cycles:
            overrides += [f"landing.cycles={cycles}", f"landing.stroke_m={float(stroke_m)!r}"]
        scene, result, wall = _solve([*overrides, *extra], folder)
        self.status = result.status
        self.entry = {"velocity_m_s": float(velocity), "run_velocity_m_s": float(speed), "status": result.status,
                      "wall_s": wall}
        self.message = result.message
        self.ok = result.status == "ok"
        if self.ok:
            h = {k: np.asarray(v, dtype=float) for k, v in result.history.items()}
            moved = h["sinkage_m"] - h["sinkage_m"][0]
            self.axis_m = scene.landing.initial_depth_m + moved - D / 2.0
            self.resistance_pa = h["force_n"] / (D * scene.geometry.contact_length_m)
            downward = h["velocity_m_s"] > 0
            self.stroke = np.cumsum(np.r_[0, np.diff(downward.astype(int)) != 0])

    def mean_at(self, depth_m: float, stroke: int = 0) -> float:
        """The mean resistance (Pa) while the axis is within D/2 of ``depth_m`` in that stroke (NaN if never)."""
        here = (self.stroke == stroke) & (np.abs(self.axis_m - depth_m) <= self.diameter_m / 2.0)
        return float(np.mean(self.resistance_pa[here])) if here.any() else float("nan")


def profile_push(soil, diameter_m: float, velocity: float, deepest_m: float, cells: int, folder: Path,
                 shallowest_m: float | None = None, extra: tuple[str, ...] = ()) -> TbarPush:
    """A monotonic push whose resistance is steady from ``shallowest_m`` (default: as soon as it can be)
    down to ``deepest_m``: it starts :data:`STEADY_TRAVEL_DIAMETERS` − ½ above the shallowest depth read,
    no shallower than :data:`SHALLOWEST_AXIS_DIAMETERS`."""
    D = diameter_m
    settle = (STEADY_TRAVEL_DIAMETERS - 0.5) * D
    top = SHALLOWEST_AXIS_DIAMETERS * D
    start = top if shallowest_m is None else max(shallowest_m - settle, top)
    return TbarPush(soil, D, velocity, start, deepest_m + 0.5 * D - start, cells, folder, extra=extra)


def steady_from(push: TbarPush) -> float:
    """The shallowest depth (m) a profile push reads as steady."""
    return float(push.axis_m[0]) + (STEADY_TRAVEL_DIAMETERS - 0.5) * push.diameter_m


def cyclic_push(soil, diameter_m: float, velocity: float, depth_m: float, cycles: int, cells: int,
                folder: Path, extra: tuple[str, ...] = ()) -> TbarPush:
    """Down to ``depth_m`` + half a stroke of :data:`STROKE_DIAMETERS`, then ``cycles`` strokes up and
    down: penetration stroke c (1, 2, …) passes ``depth_m`` in the history's stroke 2·(c − 1)."""
    D = diameter_m
    stroke = STROKE_DIAMETERS * D
    bottom = depth_m + 0.5 * stroke                       # the bar's axis at the strokes' bottom
    start = max(bottom - STEADY_TRAVEL_DIAMETERS * D, SHALLOWEST_AXIS_DIAMETERS * D)
    return TbarPush(soil, D, velocity, start, bottom - start, cells, folder, cycles, stroke, extra)


def cone_drop(soil, mass_kg: float, apex_angle_deg: float, sample_depth_m: float, folder: Path,
              extra: tuple[str, ...] = ()) -> tuple[float, str, float]:
    """A fall cone released from rest on a sample taken at ``sample_depth_m``: uniform at the soil's
    intact strength there, its law's values, on the axisymmetric CEL's cone mesh. Returns the depth (m)
    at which it stopped, the run's status and its wall time (s)."""
    su = float(soil.strength.su(sample_depth_m))
    sample = soil.model_copy(update={"su0_pa": su, "ks_pa_per_m": 0.0, "profile": None, "profile_scale": 1.0})
    width = 2.0 * CONE_LENGTH_M * math.tan(math.radians(apex_angle_deg) / 2.0)
    scene, result, wall = _solve(["geometry=fall_cone_30deg", f"geometry.apex_angle_deg={float(apex_angle_deg)!r}",
                                  f"geometry.width_m={width!r}", f"landing.mass_kg={float(mass_kg)!r}",
                                  "output.plots=false", *soil_overrides(sample), *extra], folder)
    return float(result.metrics.get("max_sinkage_m", float("nan"))), result.status, wall


def measure(test: SiteTest, soil, cells: int, folder: Path, cycles: int | None = None,
            extra: tuple[str, ...] = (), pushes: int = 0) -> SiteTest:
    """``test``'s design run on the CEL in ``soil``: the rows it measured, their values clean. ``extra``:
    overrides for every run (a solver setting); ``pushes``: a profile read by that many short pushes, each
    to one of its depths, in place of one push through it."""
    c, D = test.columns, test.diameter_m
    if test.kind == "fall_cone":
        depths = []
        for i, (mass, sample) in enumerate(zip(c["mass"], c["sample_depth"])):
            depth, status, wall = cone_drop(soil, mass, test.apex_angle_deg, sample, folder / f"{test.name}_{i}", extra)
            print(f"  {test.name}: {mass * 1e3:g} g cone, sample from {sample:g} m: {depth * 1e3:.3f} mm "
                  f"({status}, {wall:.0f} s)", flush=True)
            depths.append(depth if status == "ok" else math.nan)
        rows = {**c, "penetration": np.array(depths)}
    elif len(np.unique(c["cycle"])) > 1:
        depth, velocity = float(np.median(c["depth"])), float(np.median(c["velocity"]))
        n = int(c["cycle"].max()) if cycles is None else cycles
        push = cyclic_push(soil, D, velocity, depth, n - 1, cells, folder / f"{test.name}_cycles", extra)
        values = [push.mean_at(depth, 2 * (k - 1)) if push.ok else math.nan for k in range(1, n + 1)]
        print(f"  {test.name}: {n} cycles at {depth:g} m: " + ", ".join(f"{q / 1e3:.2f}" for q in values)
              + f" kPa ({push.status}, {push.entry['wall_s']:.0f} s{'' if push.ok else ': ' + push.message})", flush=True)
        rows = {"depth": np.full(n, depth), "velocity": np.full(n, velocity), "cycle": np.arange(1.0, n + 1),
                "resistance": np.array(values)}
    else:
        parts = []
        for velocity in np.unique(c["velocity"]):
            at = c["velocity"] == velocity
            depths = c["depth"][at]
            if pushes:  # one push of STEADY_TRAVEL_DIAMETERS to each of `pushes` depths spread over the rows'
                steady = depths[depths >= (SHALLOWEST_AXIS_DIAMETERS + STEADY_TRAVEL_DIAMETERS - 0.5) * D]
                ends = np.unique(steady[np.linspace(0, len(steady) - 1, pushes).round().astype(int)])
                runs = [(np.array([z]), profile_push(soil, D, velocity, float(z), cells, folder / f"{test.name}_v{velocity:g}"
                                                     f"_z{z:g}", shallowest_m=float(z), extra=extra)) for z in ends]
            else:     # one push through the profile, read from where it is steady
                push = profile_push(soil, D, velocity, float(depths.max()), cells, folder / f"{test.name}_v{velocity:g}",
                                    extra=extra)
                runs = [(depths[depths >= steady_from(push)] if push.ok else depths[:0], push)]
            for read, push in runs:
                if push.ok:
                    parts.append((read, np.full(len(read), velocity), np.array([push.mean_at(z) for z in read])))
                print(f"  {test.name}: {velocity * 1e3:g} mm/s, " + (
                    f"{len(read)} depths from {push.axis_m[0]:.3f} m" if push.ok else "no depth read, the push ended")
                    + f" ({push.status}, {push.entry['wall_s']:.0f} s{'' if push.ok else ': ' + push.message})", flush=True)
        read, velocity, values = (np.concatenate(x) for x in zip(*parts)) if parts else (np.empty(0),) * 3
        rows = {"depth": read, "velocity": velocity, "cycle": np.ones(len(read)), "resistance": values}
    kept = np.isfinite(rows[("penetration" if test.kind == "fall_cone" else "resistance")])
    return SiteTest(test.kind, test.name, rows, D, test.apex_angle_deg).rows(kept)


__all__ = ["measure", "TbarPush", "profile_push", "cyclic_push", "cone_drop", "steady_from", "tbar_overrides", "soil_overrides",
           "SPEED_DIAMETERS_PER_S", "STEADY_TRAVEL_DIAMETERS", "STROKE_DIAMETERS"]
