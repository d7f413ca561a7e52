"""The Table 3 dataset design: a seeded Latin hypercube snapped to the study's discrete levels.

Table 3 of the reference study (Zeng et al. 2025) lists the levels each parameter takes in its
257 CEL samples. We draw a Latin hypercube in the unit cube (``scipy.stats.qmc``, one column per
parameter) and snap each coordinate u ∈ [0, 1) to level ``floor(u·k)`` of that parameter's k
levels: every level of every parameter is drawn in equal proportion (up to one sample), and the
combinations fill the space rather than a product grid.

Table 3's full ranges reach metre-scale sinkage, while the study's own sinkages span
0.04–0.46 m: over the full product of Table 3's levels of m, A, vi, su0 and ks, the energy
method below puts 67 % of the combinations above 1 m (8 % cannot be stopped at all: ks = 0 and
the mudline capacity below the weight). About 30 % of a hypercube survives a 1 m limit. Scenes whose analytic
sinkage (:func:`dsmv.analytic.energy.energy_estimate`, its default settings: Nc = 2 + π,
Skempton's shape factor, no softening, no rate effect) exceeds ``dataset.max_analytic_sinkage_m``
are dropped, and so are scenes the soil cannot stop at all. To still run ``dataset.n_samples``
scenes, the hypercube is redrawn larger (same seed) until enough survive; the first
``n_samples`` survivors in the hypercube's (random) order are kept. The report says how many
were drawn, dropped (by reason) and kept.

The contact area A enters through the contact length L = A/B with the geometry's width B
(0.6 m for the Pioneering-I track).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dsmv.analytic.energy import energy_estimate, sinkage_from_energy
from dsmv.config.scene import build_scene, build_tracking
from dsmv.errors import ConfigError
from dsmv.tracking import runs

#: Table 3 of Zeng et al. (2025): the levels of each parameter in the 257-sample dataset.
#: Keys are the config keys; the contact area A (m²) is turned into L = A/B below.
TABLE3_LEVELS: dict[str, tuple[float, ...]] = {
    "landing.mass_kg": (2500.0, 3000.0, 4500.0, 6500.0, 8500.0, 9000.0, 10500.0),  # m (kg)
    "contact_area_m2": (1.87, 2.18, 2.5, 2.81, 3.12),  # A (m²)
    "landing.velocity_m_s": (1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0),  # vi (m/s)
    "soil.rate.eta": (0.0, 0.01, 0.04, 0.05, 0.1, 0.15),  # η (-)
    "soil.sensitivity": (1.0, 2.0, 2.5, 3.0, 3.33, 4.0, 5.0, 8.0, 10.0),  # St (-)
    "soil.xi95": (10.0, 15.0, 20.0, 25.0, 30.0, 40.0, 50.0),  # ξ95 (-)
    "soil.su0_pa": (2000.0, 2500.0, 3000.0, 5000.0, 6000.0, 7500.0, 9000.0, 10000.0),  # su0 (Pa)
    "soil.ks_pa_per_m": (0.0, 1000.0, 2000.0, 2500.0, 3000.0),  # ks (Pa/m)
}
CONTACT_LENGTH_KEY = "geometry.contact_length_m"
DESIGN_FILE = "dataset_design.csv"
MAX_REDRAWS = 20  # enlargements of the hypercube before giving up (each by the survival rate)


def block_values(cfg, name: str, block_class, missing: str) -> dict:
    """The fields of the dataclass ``block_class`` read from the config block ``name`` (its defaults
    where the block is silent); a one-line ConfigError saying ``missing`` without the block."""
    block = cfg.get(name) if hasattr(cfg, "get") else None
    if block is None:
        raise ConfigError(name, None, f"missing: {missing}")
    return {f.name: block.get(f.name, f.default) for f in dataclasses.fields(block_class)}


@dataclass(frozen=True)
class DatasetConfig:
    """The ``dataset`` block of ``experiment=dataset_table3``."""

    n_samples: int = 257  # scenes to run (-), the study's 257
    seed: int = 2025  # seed of the Latin hypercube (-)
    max_analytic_sinkage_m: float = 1.0  # operational limit on the energy-method sinkage (m)
    jobs: str | None = None  # "start:stop": run only these scenes of the design (resume failed ones)

    @classmethod
    def from_cfg(cls, cfg) -> "DatasetConfig":
        values = block_values(cfg, "dataset", cls, "the Table 3 design needs a dataset block "
                                                   "(use experiment=dataset_table3)")
        n, seed, limit = values["n_samples"], values["seed"], values["max_analytic_sinkage_m"]
        if isinstance(n, bool) or not isinstance(n, int) or n < 1:
            raise ConfigError("dataset.n_samples", n, "must be an integer ≥ 1")
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            raise ConfigError("dataset.seed", seed, "must be an integer ≥ 0")
        if isinstance(limit, bool) or not isinstance(limit, (int, float)) or not limit > 0:
            raise ConfigError("dataset.max_analytic_sinkage_m", limit, "must be a number > 0 (m)")
        jobs = values["jobs"]
        if jobs is not None and not _parse_slice(str(jobs)):
            raise ConfigError("dataset.jobs", jobs, "must be null (all scenes) or 'start:stop', scene numbers of the design")
        return cls(n, seed, float(limit), None if jobs is None else str(jobs))

    def selected(self) -> slice:
        """The scenes of the design this sweep runs."""
        return slice(None) if self.jobs is None else _parse_slice(self.jobs)


def _parse_slice(text: str) -> slice | None:
    start, sep, stop = text.partition(":")
    try:
        bounds = [int(v) if v.strip() else None for v in (start, stop)]
    except ValueError:
        return None
    if not sep or any(b is not None and b < 0 for b in bounds):
        return None
    return slice(*bounds)


@dataclass(frozen=True)
class Design:
    """A filtered design: the kept scenes as override dicts and what the filter did."""

    scenes: list[dict[str, float]]  # config key → value, one dict per kept scene
    analytic_sinkage_m: list[float]  # the energy-method sinkage of each kept scene (m)
    n_drawn: int  # points of the final hypercube (-)
    dropped: dict[str, int]  # reason → count, over the final hypercube

    def report(self, limit_m: float) -> str:
        reasons = ", ".join(f"{n} {why}" for why, n in self.dropped.items()) or "none"
        return (f"dataset_table3: drew {self.n_drawn} Latin-hypercube scenes over Table 3's levels, "
                f"dropped {sum(self.dropped.values())} (analytic sinkage limit {limit_m:g} m: {reasons}), "
                f"running {len(self.scenes)}")

    def overrides(self, selected: slice = slice(None)) -> list[list[str]]:
        """One list of Hydra override strings per scene (of the ``selected`` ones)."""
        return [[f"{key}={value!r}" for key, value in scene.items()] for scene in self.scenes[selected]]


def latin_hypercube_levels(n: int, seed: int, levels: dict[str, tuple[float, ...]] = TABLE3_LEVELS) -> np.ndarray:
    """``n`` points of a seeded Latin hypercube, snapped to level indices: (n, n_parameters) ints."""
    from scipy.stats import qmc

    unit = qmc.LatinHypercube(d=len(levels), seed=np.random.default_rng(seed)).random(n)
    counts = np.array([len(v) for v in levels.values()])
    return np.minimum(np.floor(unit * counts).astype(int), counts - 1)


def _scene_values(indices: np.ndarray, width_m: float) -> list[dict[str, float]]:
    """Level indices → config values; the contact area becomes the contact length L = A/B (m)."""
    scenes = []
    for row in indices:
        scene: dict[str, float] = {}
        for (key, levels), i in zip(TABLE3_LEVELS.items(), row):
            if key == "contact_area_m2":
                scene[CONTACT_LENGTH_KEY] = round(levels[i] / width_m, 9)
            else:
                scene[key] = levels[i]
        scenes.append(scene)
    return scenes


def analytic_sinkage(base_scene, scenes: list[dict[str, float]]) -> list[float]:
    """The energy-method sinkage (m) of ``base_scene`` with each scene's values; inf if unstoppable.

    The method's resistance per unit strength, Ra = Nc·sc·f·A (m²), depends on the body only:
    :func:`~dsmv.analytic.energy.energy_estimate` gives it once per contact length, and
    :func:`~dsmv.analytic.energy.sinkage_from_energy` solves each scene.
    """
    resistance_area: dict[float, float] = {}
    out = []
    for values in scenes:
        length = values[CONTACT_LENGTH_KEY]
        if length not in resistance_area:
            geometry = base_scene.geometry.model_copy(update={"contact_length_m": length})
            scene = dataclasses.replace(base_scene, geometry=geometry)
            resistance_area[length] = energy_estimate(scene).resistance_area_m2
        landing = base_scene.landing.model_copy(update={"mass_kg": values["landing.mass_kg"],
                                                        "velocity_m_s": values["landing.velocity_m_s"]})
        out.append(sinkage_from_energy(landing.weight_per_track_n, landing.inertia_per_track_kg,
                                       landing.velocity_m_s, resistance_area[length],
                                       values["soil.su0_pa"], values["soil.ks_pa_per_m"]))
    return out


def table3_design(base_scene, dataset: DatasetConfig) -> Design:
    """Draw, snap and filter the design for ``base_scene`` (its other settings stay as they are)."""
    n_draw = dataset.n_samples
    for _ in range(MAX_REDRAWS):
        scenes = _scene_values(latin_hypercube_levels(n_draw, dataset.seed), base_scene.geometry.width_m)
        sinkage = analytic_sinkage(base_scene, scenes)
        kept = [i for i, z in enumerate(sinkage) if z <= dataset.max_analytic_sinkage_m]
        if len(kept) >= dataset.n_samples:
            break
        # enlarge by the observed survival rate, with some slack
        n_draw = math.ceil(1.1 * n_draw * dataset.n_samples / max(len(kept), 1))
    else:
        raise ConfigError("dataset.max_analytic_sinkage_m", dataset.max_analytic_sinkage_m,
                          f"too strict: fewer than {dataset.n_samples} of {n_draw} scenes stay below it")
    unstoppable = sum(math.isinf(z) for z in sinkage)
    dropped = {f"above {dataset.max_analytic_sinkage_m:g} m": len(sinkage) - len(kept) - unstoppable}
    if unstoppable:
        dropped["bearing failure (the soil cannot stop the track)"] = unstoppable
    kept = kept[: dataset.n_samples]
    return Design([scenes[i] for i in kept], [sinkage[i] for i in kept], n_drawn=n_draw, dropped=dropped)


def write_design(design: Design, path: Path) -> Path:
    """The kept scenes and their analytic sinkage as CSV (one row per job, in job order)."""
    import csv

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(["job", *design.scenes[0], "analytic_sinkage_m"])
        for job, (scene, z) in enumerate(zip(design.scenes, design.analytic_sinkage_m)):
            writer.writerow([job, *scene.values(), z])
    return path


def table3_cases(cfg: Any) -> list[list[str]]:
    """``hydra.sweeper.cases_from`` of ``experiment=dataset_table3``: one override list per scene.

    Also prints the filter report, writes it with the design to ``dataset_design.csv`` in the
    sweep dir, and logs it to the sweep's parent MLflow run (when tracking made one).
    """
    from omegaconf import OmegaConf

    dataset = DatasetConfig.from_cfg(cfg)
    plain = OmegaConf.create({k: cfg[k] for k in cfg if k != "hydra"})
    design = table3_design(build_scene(plain), dataset)
    report = design.report(dataset.max_analytic_sinkage_m)
    cases = design.overrides(dataset.selected())
    if dataset.jobs is not None:
        report += f"; this sweep runs scenes {dataset.jobs} ({len(cases)} jobs)"
    print(report)
    sweep_dir = _sweep_dir(cfg)
    if sweep_dir is not None:
        write_design(design, sweep_dir / DESIGN_FILE)
        _log_to_parent(cfg, sweep_dir, design)
    return cases


def _sweep_dir(cfg) -> Path | None:
    try:
        return Path(str(cfg.hydra.sweep.dir))
    except Exception:  # composed without the hydra node (tests, notebooks)
        return None


def _log_to_parent(cfg, sweep_dir: Path, design: Design) -> None:
    """The design's counts as metrics of the sweep's parent run, and the design CSV as an artifact."""
    run_id = runs.parent_run_id(sweep_dir)
    settings = build_tracking(cfg)
    if run_id is None or not settings.enabled:
        return
    client = runs._client(settings)
    client.log_metric(run_id, "dataset_n_drawn", design.n_drawn)
    client.log_metric(run_id, "dataset_n_dropped", sum(design.dropped.values()))
    client.log_metric(run_id, "dataset_n_kept", len(design.scenes))
    client.log_artifact(run_id, str(sweep_dir / DESIGN_FILE))
