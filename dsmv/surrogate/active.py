"""Active learning: CEL runs added in batches where the surrogate is least certain.

``experiment=dataset_active`` is a sweep whose cases this module picks (``hydra.sweeper.cases_from``),
one batch per sweep, from what the store already holds for the study:

- the candidates are a seeded Latin hypercube over Table 3's levels (``active.pool`` scenes, the
  same draw and energy-method filter as ``experiment=dataset_table3``);
- while the study has fewer than ``active.initial`` ok runs, the batch is the hypercube's first
  ``active.initial`` candidates not yet run: a space-filling start;
- after that, a random forest on the physics features (:class:`~dsmv.surrogate.fast_model.PhysicsFeatures`)
  is fitted to the tracked runs, and each candidate not yet run is scored by how much its z/B
  varies between the forest's trees (the ensemble's disagreement). The most disputed candidates
  crowd together (one batch of the 20 top-scored ones all sank 0.26–0.29 m), so the batch is
  spread: the ``DIVERSITY·batch`` most disputed are grouped into ``batch`` clusters (k-means on
  the standardised inputs) and each cluster gives its most disputed member.

Every sweep is tracked as any other (``dsmv.study = dataset_active``), so ``dsmv-train
train.study=dataset_active`` trains on it, and an interrupted batch is resumed with ``resume=true``.

``python -m dsmv.surrogate.active`` compares the design with the plain Latin hypercube: both train
the same forest on their first n runs, scored on a fixed held-out set of the hypercube's runs.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from dsmv.config.scene import build_scene, build_tracking
from dsmv.errors import ConfigError
from dsmv.surrogate.dataset import COLUMNS, DatasetError, load_dataset, search_study_runs
from dsmv.surrogate.design import CONTACT_LENGTH_KEY, DatasetConfig, TABLE3_LEVELS, block_values, table3_design
from dsmv.surrogate.evaluate import pyplot
from dsmv.surrogate.fast_model import PhysicsFeatures
from dsmv.surrogate.features import LeakFreeFeatures, target
from dsmv.surrogate.model import scene_table
from dsmv.tracking.run_writer import store_missing

#: the forest that measures disagreement (its trees' spread) and scores the comparison
FOREST = {"n_estimators": 200, "min_samples_leaf": 2}
#: a batch is drawn from this many times its size of the most disputed candidates, one per cluster
DIVERSITY = 5


@dataclass(frozen=True)
class ActiveConfig:
    """The ``active`` block of ``experiment=dataset_active``."""

    initial: int = 40                     # space-filling runs before the first uncertain batch (-)
    batch: int = 20                       # runs added per sweep (-)
    pool: int = 2000                      # candidate scenes (-)
    seed: int = 2026                      # seed of the candidates' hypercube and of the forest (-)
    max_analytic_sinkage_m: float = 1.0   # candidates whose energy-method sinkage exceeds this are dropped (m)

    @classmethod
    def from_cfg(cls, cfg) -> "ActiveConfig":
        values = block_values(cfg, "active", cls, "active learning needs an active block "
                                                  "(use experiment=dataset_active)")
        for name in ("initial", "batch", "pool"):
            value = values[name]
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ConfigError(f"active.{name}", value, "must be an integer ≥ 1")
        return cls(**values)


def candidates(base_scene, active: ActiveConfig) -> pd.DataFrame:
    """The candidate scenes as a dataset table (the base scene's values where the design is silent)."""
    design = table3_design(base_scene, DatasetConfig(active.pool, active.seed, active.max_analytic_sinkage_m))
    table = pd.concat([scene_table([base_scene])] * len(design.scenes), ignore_index=True)
    for column in {COLUMNS[key] for scene in design.scenes for key in scene}:
        key = next(k for k, c in COLUMNS.items() if c == column)
        table[column] = [float(scene[key]) for scene in design.scenes]
    return table


def _identity(table: pd.DataFrame) -> list[tuple]:
    return [tuple(np.round(row, 9)) for row in table[[c for c in COLUMNS.values()]].fillna(-1.0).to_numpy(float)]


def tree_spread(tracked: pd.DataFrame, pool: pd.DataFrame, seed: int) -> np.ndarray:
    """The standard deviation of z/B over the trees of a forest fitted to ``tracked``, per pool row."""
    from sklearn.ensemble import RandomForestRegressor

    features = PhysicsFeatures()
    forest = RandomForestRegressor(random_state=seed, **FOREST).fit(features.transform(tracked), target(tracked))
    X = features.transform(pool).to_numpy(float)
    return np.std([tree.predict(X) for tree in forest.estimators_], axis=0)


def choose(pool: pd.DataFrame, tracked: pd.DataFrame | None, active: ActiveConfig) -> tuple[np.ndarray, str]:
    """Row numbers of the next batch in ``pool``, and how they were chosen."""
    done = set(_identity(tracked)) if tracked is not None else set()
    fresh = np.array([i for i, key in enumerate(_identity(pool)) if key not in done], dtype=int)
    n_done = 0 if tracked is None else len(tracked)
    if n_done < active.initial:
        return fresh[: active.initial - n_done], f"space-filling start ({n_done} of {active.initial} runs tracked)"
    spread = tree_spread(tracked, pool.iloc[fresh].reset_index(drop=True), active.seed)
    order = spread_batch(pool.iloc[fresh].reset_index(drop=True), spread, active.batch, active.seed)
    return fresh[order], (f"{len(order)} of the {min(len(fresh), DIVERSITY * active.batch)} candidates (of {len(fresh)}) "
                          f"the forest on {n_done} runs is least sure of, one per cluster "
                          f"(tree spread of z/B {spread[order].min():.3g}–{spread[order].max():.3g})")


def spread_batch(candidates_: pd.DataFrame, spread: np.ndarray, batch: int, seed: int) -> np.ndarray:
    """Row numbers of a batch: the most disputed member of each of ``batch`` k-means clusters of the
    ``DIVERSITY·batch`` most disputed candidates (standardised inputs)."""
    from sklearn.cluster import KMeans

    top = np.argsort(-spread, kind="stable")[: DIVERSITY * batch]
    if len(top) <= batch:
        return top
    inputs = LeakFreeFeatures().transform(candidates_.iloc[top]).to_numpy(float)
    scale = inputs.std(axis=0)
    inputs = (inputs - inputs.mean(axis=0)) / np.where(scale > 0, scale, 1.0)
    labels = KMeans(batch, n_init=10, random_state=seed).fit_predict(inputs)
    return np.array([top[labels == k][np.argmax(spread[top][labels == k])] for k in range(batch)])


def next_batch(cfg: Any) -> list[list[str]]:
    """``hydra.sweeper.cases_from`` of ``experiment=dataset_active``: the next batch's overrides."""
    from omegaconf import OmegaConf

    active = ActiveConfig.from_cfg(cfg)
    plain = OmegaConf.create({k: cfg[k] for k in cfg if k != "hydra"})
    base = build_scene(plain)
    pool = candidates(base, active)
    tracking = build_tracking(plain)
    tracked = None
    # a store not created yet holds no runs (and the sweep's own tracking is creating it meanwhile)
    if tracking.enabled and not store_missing(tracking.uri):
        try:
            tracked = load_dataset(tracking.uri, str(cfg.study)).table
        except DatasetError:
            pass
    rows, how = choose(pool, tracked, active)
    print(f"dataset_active: {how}: running {len(rows)}")
    keys = [CONTACT_LENGTH_KEY if key == "contact_area_m2" else key for key in TABLE3_LEVELS]
    return [[f"{key}={float(pool.at[i, COLUMNS[key]])!r}" for key in keys] for i in rows]


# ------------------------------------------------------------------------------------- comparison


def _ordered(tracking_uri: str, study: str) -> pd.DataFrame:
    """The study's ok runs, oldest first (the order a design added them in)."""
    dataset = load_dataset(tracking_uri, study)
    started = {run.info.run_id: run.info.start_time or 0 for run in search_study_runs(tracking_uri, study)}
    order = np.argsort([started[r] for r in dataset.table["run_id"]], kind="stable")
    return dataset.table.iloc[order].reset_index(drop=True)


def held_out_r2(train: pd.DataFrame, test: pd.DataFrame, seed: int) -> float:
    """R² on z/B of the comparison forest (physics features) fitted to ``train``, on ``test``."""
    from sklearn.ensemble import RandomForestRegressor
    from sklearn.metrics import r2_score

    features = PhysicsFeatures()
    forest = RandomForestRegressor(random_state=seed, **FOREST).fit(features.transform(train), target(train))
    return float(r2_score(target(test), forest.predict(features.transform(test))))


def compare(tracking_uri: str, active_study: str = "dataset_active", plain_study: str = "dataset_table3",
            held_out: int = 57, seed: int = 0) -> pd.DataFrame:
    """Held-out R² against the number of runs, for the active design and the plain hypercube.

    The held-out set is ``held_out`` of the plain study's runs (seeded); the plain design's curve uses
    the others in a seeded random order, the active design's its runs in the order they were added."""
    plain = load_dataset(tracking_uri, plain_study).table
    rng = np.random.default_rng(seed)
    order = rng.permutation(len(plain))
    test, rest = plain.iloc[order[:held_out]], plain.iloc[order[held_out:]].reset_index(drop=True)
    active = _ordered(tracking_uri, active_study)
    # both curves at the sizes the active design reached, and the plain one on to all its runs
    sizes = sorted({*range(20, len(active) + 1, 20), len(active), *range(20, len(rest) + 1, 20), len(rest)})
    rows = []
    for n in sizes:
        if n <= len(active):
            rows.append({"design": "active", "n_runs": n, "held_out_r2": held_out_r2(active.iloc[:n], test, seed)})
        if n <= len(rest):
            rows.append({"design": "latin_hypercube", "n_runs": n, "held_out_r2": held_out_r2(rest.iloc[:n], test, seed)})
    return pd.DataFrame(rows)


def plot_comparison(curves: pd.DataFrame, path: Path) -> Path:
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6, 4), constrained_layout=True)
    for design, frame in curves.groupby("design"):
        ax.plot(frame["n_runs"], frame["held_out_r2"], "o-", label=design.replace("_", " "))
    final = curves[curves["design"] == "latin_hypercube"]["held_out_r2"].iloc[-1]
    ax.axhline(final, color="0.5", lw=0.8, ls="--", label="hypercube, all its runs")
    ax.set_xlabel("CEL runs trained on")
    ax.set_ylabel("held-out R² on z/B")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return Path(path)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(prog="python -m dsmv.surrogate.active", description=__doc__.split("\n\n")[0])
    parser.add_argument("--tracking-uri", default="sqlite:///runs/mlflow.db", help="the store of both studies")
    parser.add_argument("--held-out", type=int, default=57, help="plain-design runs held out for scoring")
    parser.add_argument("--out", default="active_vs_latin_hypercube", help="CSV and PNG name (no suffix)")
    args = parser.parse_args(argv)
    curves = compare(args.tracking_uri, held_out=args.held_out)
    curves.to_csv(f"{args.out}.csv", index=False)
    plot_comparison(curves, Path(f"{args.out}.png"))
    plain = curves[curves["design"] == "latin_hypercube"]
    active = curves[curves["design"] == "active"]
    goal = plain["held_out_r2"].iloc[-1]
    reached = active[active["held_out_r2"] >= goal]
    print(f"latin hypercube, all {plain['n_runs'].iloc[-1]} runs: held-out R² {goal:.4f}")
    for _, row in active.iterrows():
        print(f"active, {row['n_runs']:>3} runs: {row['held_out_r2']:.4f}")
    print("active reaches it with " + (f"{reached['n_runs'].iloc[0]} runs ({reached['n_runs'].iloc[0] / plain['n_runs'].iloc[-1]:.0%})"
                                       if len(reached) else "none of its runs so far"))
    print(f"wrote {args.out}.csv and {args.out}.png")


if __name__ == "__main__":
    main()
