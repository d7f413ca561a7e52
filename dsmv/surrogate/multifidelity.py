"""Multi-fidelity: how many 3D runs a surrogate of the 3D track needs when cheap models help it.

A 3D landing costs seconds to minutes; the fast landing model costs milliseconds and a 2D section
about a second. Three random forests on z/B, each trained on n 3D runs and scored (R²) on the same
held-out 3D runs:

- **3D only**: the scene's inputs (the leak-free features);
- **+ fast model**: the 3D fast model's z/B (``solver=analytic_dynamic_3d``, its coefficients
  refitted on the same n runs) times a correction the forest learns from the inputs and that z/B
  (the log of the 3D run's over it): a residual on a low fidelity that is free anywhere;
- **+ 2D section** (with a 2D dataset of the same study): the same, on the z/B of a forest trained on
  every 2D run, which predicts the section anywhere in milliseconds.

Each n (16, 32, 64, 128, all) is drawn ``repeats`` times from the training pool; the figure shows the
mean and the spread. ``python -m dsmv.surrogate.multifidelity DATASET_3D.csv [--section DATASET_2D.csv]``
writes ``learning_curve_multifidelity.csv`` and ``.png``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pandas as pd

from dsmv.surrogate.fast_model import calibrate, default_settings, fast_sinkage
from dsmv.surrogate.features import LeakFreeFeatures, target

SIZES = (16, 32, 64, 128)
TEST_FRACTION = 0.25


def forest(seed: int):
    from sklearn.ensemble import RandomForestRegressor

    return RandomForestRegressor(200, min_samples_leaf=1, max_features=0.6, random_state=seed, n_jobs=1)


def section_model(section: pd.DataFrame, seed: int):
    """A forest on every 2D run: the 2D section's z/B of any scene, from its inputs and the 2D fast model."""
    settings = default_settings("cel2d")
    X = LeakFreeFeatures().transform(section).assign(
        fast=fast_sinkage(section, settings=settings) / section["width_m"].to_numpy(float))
    model = forest(seed).fit(X, target(section))
    return lambda table: model.predict(LeakFreeFeatures().transform(table).assign(
        fast=fast_sinkage(table, settings=settings) / table["width_m"].to_numpy(float)))


def fit_predict(X: pd.DataFrame, y: np.ndarray, X_test: pd.DataFrame, seed: int, base=None) -> np.ndarray:
    """A forest's z/B of the test scenes: on its own, or (``base``: a low fidelity's z/B on the train
    and test scenes) the low fidelity times exp of the forest's log-ratio correction."""
    if base is None:
        return forest(seed).fit(X, y).predict(X_test)
    correction = forest(seed).fit(X, np.log(y / base[0])).predict(X_test)
    return base[1] * np.exp(correction)


def learning_curve(table: pd.DataFrame, section: pd.DataFrame | None = None, repeats: int = 5,
                   seed: int = 0) -> pd.DataFrame:
    """Held-out R² on z/B (rows: model, n, repeat) of each model trained on n of the 3D runs."""
    from sklearn.metrics import r2_score

    rng = np.random.default_rng(seed)
    order = rng.permutation(len(table))
    n_test = int(round(TEST_FRACTION * len(table)))
    test, pool = table.iloc[order[:n_test]].reset_index(drop=True), table.iloc[order[n_test:]].reset_index(drop=True)
    y_test = target(test)
    settings = default_settings("cel3d")
    low = section_model(section, seed) if section is not None else None
    rows = []
    for n in [s for s in SIZES if s < len(pool)] + [len(pool)]:
        for repeat in range(repeats if n < len(pool) else 1):
            train = pool.iloc[rng.permutation(len(pool))[:n]].reset_index(drop=True)
            y = target(train)
            inputs, inputs_test = LeakFreeFeatures().transform(train), LeakFreeFeatures().transform(test)
            fitted = calibrate(train, settings=settings)
            fast, fast_test = (fast_sinkage(t, fitted, settings) / t["width_m"].to_numpy(float) for t in (train, test))
            # name: (train features, test features, the low fidelity corrected on train and test, or None)
            models = {"3D only": (inputs, inputs_test, None),
                      "+ fast model": (inputs.assign(fast=fast), inputs_test.assign(fast=fast_test), (fast, fast_test))}
            if low is not None:
                section, section_test = low(train), low(test)
                models["+ 2D section"] = (inputs.assign(fast=fast, section=section),
                                          inputs_test.assign(fast=fast_test, section=section_test),
                                          (section, section_test))
            for name, (X, X_test, base) in models.items():
                score = r2_score(y_test, fit_predict(X, y, X_test, seed + repeat, base))
                rows.append({"model": name, "n_3d_runs": n, "repeat": repeat, "r2": score})
            print(f"  n = {n:3d}, draw {repeat}: " + ", ".join(f"{r['model']} {r['r2']:.3f}" for r in rows[-len(models):]),
                  flush=True)
    return pd.DataFrame(rows)


def plot(curve: pd.DataFrame, path: Path, n_test: int) -> Path:
    from dsmv.surrogate.evaluate import pyplot

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for name, group in curve.groupby("model", sort=False):
        stats = group.groupby("n_3d_runs")["r2"].agg(["mean", "min", "max"])
        ax.plot(stats.index, stats["mean"], "o-", label=name)
        ax.fill_between(stats.index, stats["min"], stats["max"], alpha=0.15)
    ax.set_xscale("log", base=2)
    ax.set_xlabel("3D runs trained on")
    ax.set_ylabel(f"R² on z/B, {n_test} held-out 3D runs")
    ax.set_title("Surrogates of the 3D track: 3D runs alone and with cheap models")
    ax.grid(True, alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(prog="python -m dsmv.surrogate.multifidelity", description=__doc__.split("\n\n")[0])
    parser.add_argument("dataset", help="the 3D runs' dataset.csv (dsmv-train train.solver=cel3d writes one)")
    parser.add_argument("--section", help="a dataset.csv of 2D runs (dsmv-train train.solver=cel2d)")
    parser.add_argument("--repeats", type=int, default=5, help="draws of the training runs per size")
    parser.add_argument("--out", default=".", help="folder of learning_curve_multifidelity.csv and .png")
    args = parser.parse_args(argv)
    table = pd.read_csv(args.dataset)
    section = pd.read_csv(args.section) if args.section else None
    curve = learning_curve(table, section, args.repeats)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    curve.to_csv(out / "learning_curve_multifidelity.csv", index=False)
    summary = curve.groupby(["model", "n_3d_runs"], sort=False)["r2"].agg(["mean", "min", "max"])
    print(summary.to_string(float_format=lambda v: f"{v:.4f}"))
    print(f"written {plot(curve, out / 'learning_curve_multifidelity.png', int(round(TEST_FRACTION * len(table))))}")


if __name__ == "__main__":
    main()
