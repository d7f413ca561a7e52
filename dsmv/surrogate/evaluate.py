"""The reference study's evaluation of a surrogate, one function per figure or table.

- :func:`scores`: R², MSE, MAE, RMSE (Table 5), on z/B (-).
- :func:`grid_search`: k-fold grid search on the training split (Figure 16's curves come from it).
- :func:`cross_validation`: 10-fold cross-validation over the whole dataset (Figure 19).
- :func:`monte_carlo`: 200 random 90/10 re-splits (Figure 20).
- :func:`learning_curve`: the k-fold scores against the number of CEL runs trained on.
- :func:`kendall_tau`: rank correlations of features and target (Figure 15).
- plots: Kendall heatmap, grid-search curves, predicted vs true (Figure 17), residuals
  (Figure 18), cross-validation folds, Monte Carlo running means, feature importance.

Every model is scored in the target it predicts, z/B. For the study's feature set the scores
are given twice: with the measured z inside its inputs (how the study scored it) and with z
solved from the implicit equation (what a user gets), keys ``implicit_*``.

The refits run through ``predict``: a callable ``(estimator, rows) -> z/B``, which lets the
study's set solve its implicit equation and later issues add intervals without touching this.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
import pandas as pd


def scores(y_true, y_pred) -> dict[str, float]:
    """R² (-), MSE, MAE and RMSE (units of y) of predictions."""
    from sklearn.metrics import mean_absolute_error, mean_squared_error, r2_score

    mse = float(mean_squared_error(y_true, y_pred))
    return {"r2": float(r2_score(y_true, y_pred)), "mse": mse,
            "mae": float(mean_absolute_error(y_true, y_pred)), "rmse": float(np.sqrt(mse))}


def split(n: int, test_fraction: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Row indices of a seeded random train/test split."""
    from sklearn.model_selection import train_test_split

    return train_test_split(np.arange(n), test_size=test_fraction, random_state=seed)


def grid_search(make: Callable, grid: dict, X: pd.DataFrame, y: np.ndarray, folds: int, seed: int, n_jobs: int):
    """Exhaustive k-fold grid search (R²); returns (best params, the full results table)."""
    from sklearn.model_selection import GridSearchCV, KFold

    if not grid:
        return {}, pd.DataFrame()
    search = GridSearchCV(make(), {k: list(v) for k, v in grid.items()}, scoring="r2",
                          cv=KFold(folds, shuffle=True, random_state=seed), n_jobs=n_jobs, refit=False)
    search.fit(X, y)
    return dict(search.best_params_), pd.DataFrame(search.cv_results_)


@dataclass
class Resampled:
    """Scores of repeated fits: one row per fold or split, columns like ``train_r2``, ``test_rmse``."""

    frame: pd.DataFrame

    def summary(self, prefix: str) -> dict[str, float]:
        """``{prefix}_r2_mean``/``_std`` for the test side, ``{prefix}_train_r2_mean``/``_std``, …"""
        out = {}
        for column in self.frame.columns:
            side, metric = column.split("_", 1)
            name = f"{prefix}_{metric}" if side == "test" else f"{prefix}_{side}_{metric}"
            out[f"{name}_mean"] = float(self.frame[column].mean())
            out[f"{name}_std"] = float(self.frame[column].std(ddof=1)) if len(self.frame) > 1 else 0.0
        return out


def _fit_score(make, X, y, train, test, extra: Callable | None):
    model = make().fit(X.iloc[train], y[train])
    row = {f"train_{k}": v for k, v in scores(y[train], model.predict(X.iloc[train])).items()}
    row |= {f"test_{k}": v for k, v in scores(y[test], model.predict(X.iloc[test])).items()}
    if extra is not None:
        row |= extra(model, train, test)
    return row


def cross_validation(make: Callable, X: pd.DataFrame, y: np.ndarray, folds: int, seed: int, n_jobs: int = 1,
                     extra: Callable | None = None) -> Resampled:
    """k-fold cross-validation; ``extra(model, train, test) -> {name: value}`` adds per-fold scores."""
    from joblib import Parallel, delayed
    from sklearn.model_selection import KFold

    splits = KFold(folds, shuffle=True, random_state=seed).split(X)
    rows = Parallel(n_jobs=n_jobs)(delayed(_fit_score)(make, X, y, tr, te, extra) for tr, te in splits)
    return Resampled(pd.DataFrame(rows))


def monte_carlo(make: Callable, X: pd.DataFrame, y: np.ndarray, n_splits: int, test_fraction: float, seed: int,
                n_jobs: int = 1, extra: Callable | None = None) -> Resampled:
    """``n_splits`` independent random train/test splits (seeds seed, seed+1, …), refit on each."""
    from joblib import Parallel, delayed

    jobs = (delayed(_fit_score)(make, X, y, *split(len(y), test_fraction, seed + i), extra) for i in range(n_splits))
    return Resampled(pd.DataFrame(Parallel(n_jobs=n_jobs)(jobs)))


def learning_curve(make: Callable, X: pd.DataFrame, y: np.ndarray, fractions, folds: int, seed: int,
                   n_jobs: int = 1) -> pd.DataFrame:
    """Test R² and RMSE against the number of runs trained on: in each of ``folds`` folds, the
    model is fitted on the first ``fraction`` of the training rows (in a seeded random order, so
    smaller sets are subsets of larger ones) and scored on the whole held-out fold. One row per
    fold and size: ``fraction``, ``n_runs``, ``fold``, ``test_r2``, ``test_rmse``."""
    from joblib import Parallel, delayed
    from sklearn.model_selection import KFold

    order = np.random.default_rng(seed).permutation(len(y))
    rank = np.empty(len(y), dtype=int)
    rank[order] = np.arange(len(y))
    jobs = []
    for fold, (train, test) in enumerate(KFold(folds, shuffle=True, random_state=seed).split(X)):
        ordered = train[np.argsort(rank[train])]
        for fraction in fractions:
            n = max(2, int(round(fraction * len(train))))
            jobs.append((fraction, fold, ordered[:n], test))
    fitted = Parallel(n_jobs=n_jobs)(delayed(_fit_score)(make, X, y, tr, te, None) for *_, tr, te in jobs)
    return pd.DataFrame([{"fraction": fraction, "n_runs": len(tr), "fold": fold, "test_r2": row["test_r2"],
                          "test_rmse": row["test_rmse"]} for (fraction, fold, tr, _), row in zip(jobs, fitted)])


def plot_learning_curve(curve: pd.DataFrame, path: Path) -> Path:
    """Mean test R² and RMSE (± one standard deviation over the folds) against the runs trained on."""
    plt = pyplot()
    groups = curve.groupby("fraction")
    runs = groups["n_runs"].mean()  # folds differ by a run in size
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    for ax, column, label in ((left, "test_r2", "R² on z/B"), (right, "test_rmse", "RMSE on z/B")):
        ax.errorbar(runs, groups[column].mean(), yerr=groups[column].std(), fmt="o-", capsize=3)
        ax.set_xlabel("CEL runs trained on")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    left.set_title(f"learning curve ({curve['fold'].nunique()}-fold)")
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return Path(path)


def kendall_tau(X: pd.DataFrame, y: np.ndarray, target_name: str) -> pd.DataFrame:
    """Kendall's τ-b between every pair of features and the target (the study's Eq. 4)."""
    frame = X.copy()
    frame[target_name] = y
    return frame.corr(method="kendall")


def feature_importance(estimator, columns) -> pd.Series:
    """Impurity-based (RF) or gain-based (XGBoost) importances, normalised to sum 1."""
    values = np.asarray(estimator.feature_importances_, dtype=float)
    return pd.Series(values / values.sum(), index=list(columns)).sort_values(ascending=False)


def grid_curves(results: pd.DataFrame) -> dict[str, pd.Series]:
    """Figure 16: for each hyper-parameter, the best mean CV R² reached at each of its values."""
    curves = {}
    for column in results.columns:
        if column.startswith("param_"):
            keys = results[column].astype(str)
            curves[column[len("param_"):]] = results.groupby(keys)["mean_test_score"].max()
    return curves


# ------------------------------------------------------------------------------------ plots


def pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_kendall(tau: pd.DataFrame, path: Path) -> Path:
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(1.0 + 0.7 * len(tau), 0.6 + 0.6 * len(tau)), constrained_layout=True)
    image = ax.imshow(tau.to_numpy(), cmap="RdBu_r", vmin=-1, vmax=1)
    ax.set_xticks(range(len(tau)), tau.columns, rotation=60, ha="right")
    ax.set_yticks(range(len(tau)), tau.index)
    for i in range(len(tau)):
        for j in range(len(tau)):
            ax.text(j, i, f"{tau.iat[i, j]:.2f}", ha="center", va="center", fontsize=7)
    fig.colorbar(image, ax=ax, label="Kendall τ")
    ax.set_title("Kendall rank correlation (Figure 15)")
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return Path(path)


def plot_grid_curves(curves: dict[str, pd.Series], path: Path) -> Path:
    plt = pyplot()
    fig, axes = plt.subplots(1, max(len(curves), 1), figsize=(3.2 * max(len(curves), 1), 3), constrained_layout=True,
                             squeeze=False)
    for ax, (name, curve) in zip(axes[0], curves.items()):
        ax.plot(range(len(curve)), curve.to_numpy(), "o-")
        ax.set_xticks(range(len(curve)), curve.index, rotation=30)
        ax.set_xlabel(name)
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("best mean CV R²")
    fig.suptitle("Grid search: accuracy against each hyper-parameter (Figure 16)", fontsize=10)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return Path(path)


def plot_predicted(y_train, p_train, y_test, p_test, path: Path, label: str) -> Path:
    """Predicted against true (Figure 17) and residuals against predicted (Figure 18)."""
    plt = pyplot()
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4.2), constrained_layout=True)
    hi = float(max(np.max(y_train), np.max(y_test), np.max(p_train), np.max(p_test)))
    left.plot([0, hi], [0, hi], color="grey", lw=1)
    left.scatter(y_train, p_train, s=12, alpha=0.6, label="train")
    left.scatter(y_test, p_test, s=22, marker="^", label="test")
    left.set_xlabel(f"CEL {label}")
    left.set_ylabel(f"predicted {label}")
    left.legend()
    left.grid(alpha=0.3)
    right.axhline(0, color="grey", lw=1)
    right.scatter(p_train, np.asarray(p_train) - np.asarray(y_train), s=12, alpha=0.6, label="train")
    right.scatter(p_test, np.asarray(p_test) - np.asarray(y_test), s=22, marker="^", label="test")
    right.set_xlabel(f"predicted {label}")
    right.set_ylabel("residual (predicted − CEL)")
    right.legend()
    right.grid(alpha=0.3)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return Path(path)


def plot_resampled(cv: Resampled, mc: Resampled, path: Path) -> Path:
    """Per-fold R² (Figure 19) and the running means of the Monte Carlo scores, normalised by
    their final value (Figure 20)."""
    plt = pyplot()
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    folds = np.arange(1, len(cv.frame) + 1)
    left.plot(folds, cv.frame["train_r2"], "o-", label="train")
    left.plot(folds, cv.frame["test_r2"], "s-", label="validation")
    left.set_xlabel("fold")
    left.set_ylabel("R²")
    left.set_title(f"{len(cv.frame)}-fold cross-validation")
    left.legend()
    left.grid(alpha=0.3)
    runs = np.arange(1, len(mc.frame) + 1)
    for column in ("test_r2", "test_rmse", "test_mae", "train_r2"):
        running = mc.frame[column].expanding().mean()
        right.plot(runs, running / running.iloc[-1], label=column)
    right.set_xlabel("Monte Carlo run")
    right.set_ylabel("running mean / final mean")
    right.set_title(f"{len(mc.frame)} random re-splits")
    right.legend()
    right.grid(alpha=0.3)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return Path(path)


def plot_importance(importance: pd.Series, path: Path) -> Path:
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6, 0.6 + 0.35 * len(importance)), constrained_layout=True)
    ax.barh(importance.index[::-1], importance.to_numpy()[::-1])
    ax.set_xlabel("feature importance (normalised)")
    ax.grid(alpha=0.3, axis="x")
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return Path(path)
