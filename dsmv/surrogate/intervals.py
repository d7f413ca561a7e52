"""Prediction intervals for any regressor with ``fit(X, y)`` / ``predict(X)``: cross-conformal.

Why cross-conformal (CV+ and its pooled form) rather than split conformal or quantile models
-------------------------------------------------------------------------------------------
Split conformal sets aside a calibration set that the model never trains on. With the study's
~257 CEL runs that costs a quarter of the data for a calibration quantile estimated from ~60
residuals (its own sampling error is then ±4 % of coverage). Quantile forests or quantile
XGBoost give no coverage guarantee and would need a loss per plugin. Cross-conformal uses every
run for both: K models are fitted with one fold held out each, and every run gets an
*out-of-fold* absolute residual ``R_i = |y_i − μ₋ₖ₍ᵢ₎(x_i)|``. Two ways to use them:

``pooled`` (default; what a registered model serves)
    ``mid = μ(x)`` (the model fitted on all rows) and ``[mid − q, mid + q]`` with
    ``q = R_(⌈c·(n+1)⌉)``, the ⌈c·(n+1)⌉-th smallest of the n residuals (c the confidence).
    One number per confidence travels with the model (``conformal.json``, see
    :func:`calibration_record`), prediction costs one model call. Coverage is not guaranteed in
    theory for unstable learners (the full-data model is a little better than the fold models,
    so the interval is, if anything, conservative); it is *measured* by
    :func:`coverage_over_resplits`.
``oob`` (for bagged ensembles such as the random forest)
    As ``pooled``, with each run's residual taken from the trees that did not see it in their
    bootstrap sample (``oob_prediction_``): one fit instead of K + 1, the out-of-bag analogue of
    the jackknife+-after-bootstrap (Kim, Xu & Barber 2020, NeurIPS). The estimator must accept
    ``oob_score`` (scikit-learn's forests); dsmv-train picks it for those.
``cv_plus`` (Barber, Candès, Ramdas & Tibshirani 2021, "Predictive inference with the
    jackknife+", Ann. Stat. 49)
    ``lower = q̂⁻{μ₋ₖ₍ᵢ₎(x) − R_i}``, ``upper = q̂⁺{μ₋ₖ₍ᵢ₎(x) + R_i}`` over the n runs, with the
    same finite-sample rank; guaranteed coverage ≥ 1 − 2·(1 − c) (in practice ≈ c), but it needs
    all K fold models at prediction time.

Scores: absolute or scaled (normalised conformal)
-------------------------------------------------
``score="absolute"`` calibrates ``R_i = |y_i − ŷ_i|``: a constant-width interval in the target.
CEL sinkage is heteroscedastic: a surrogate's error grows with the sinkage itself, so constant
width is too wide for shallow landings and too narrow for deep ones (on the 257 Table 3 runs the
random forest's 90 % intervals covered 99.6 % where ŷ is in the shallow third of z/B and 76.5 %
in the deep third, and the inverse answers, which sit at the deep end, overshot the limit).

``score="scaled"`` (dsmv-train's default) calibrates the normalised score
``R_i = |y_i − ŷ_i| / s(ŷ_i)`` and serves ``ŷ ± q·s(ŷ)``, with a difficulty model
``s(ŷ) = a + b·|ŷ|`` fitted to the same out-of-fold absolute residuals by non-negative least
squares (Papadopoulos, Vovk & Gammerman 2011, "Regression conformal prediction with nearest
neighbours", JAIR 40, normalised nonconformity; Lei et al. 2018, JASA 113, §5.2 "locally
weighted", who fit the MAD by a second regressor). The intercept a keeps shallow predictions
from zero-width intervals; the slope b widens them with the sinkage; neither is a tuned
constant. The same finite-sample rank applies, so the marginal guarantee is unchanged; what
changes is *where* the misses fall. A pure relative score (s = |ŷ|) undercovered the shallow
third instead (80.6 %); the fitted intercept is what balances the two ends. ŷ_i is the
out-of-fold (or out-of-bag) prediction, the same one the residual uses.

``score="binned"`` (dsmv-train's default) takes s(ŷ) as the mean absolute residual of the runs
whose out-of-fold ŷ lies in the same of ``SCORE_BINS`` quantile bins of ŷ (:class:`BinnedScale`):
with the fast landing model among the features, the residuals are no longer linear in ŷ (the
forest on them, scaled: 78 % coverage in the shallow third, 99.7 % in the middle one). Each run
is scored with its own residual left out of its bin's mean, the binned analogue of the out-of-bag
residual, so that the calibration does not grade a run by a scale it helped set.

Coverage holds on average over scenes, not per scene; :class:`Coverage` also reports it per
tercile of the true target so the deep end is checked on its own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Literal

import numpy as np

from dsmv.surrogate.evaluate import split

METHODS = ("pooled", "cv_plus", "oob")
#: the calibration record, an artifact of the registered model's training run (written by dsmv-train, read by dsmv-predict)
CALIBRATION_FILE = "conformal.json"
SCORES = ("absolute", "scaled", "binned")
#: bins of ŷ of the binned score's difficulty model (-); fewer when there are under 4 runs a bin
SCORE_BINS = 8
#: the binned scale never falls below this fraction of the median absolute residual: a bin whose
#: residuals happen to be tiny would otherwise serve near-zero widths
SCALE_FLOOR = 0.1


@dataclass(frozen=True)
class ScoreScale:
    """The difficulty model s(ŷ) = intercept + slope·|ŷ| of the conformal score (units of y, units
    of y per unit of y); the absolute score is (1, 0)."""

    intercept: float = 1.0
    slope: float = 0.0

    def __post_init__(self):
        for name in ("intercept", "slope"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ValueError(f"scale {name} = {value!r}: must be a finite number ≥ 0")
        if self.intercept == 0 and self.slope == 0:
            raise ValueError("scale intercept and slope are both 0: the scale must be positive")

    def __call__(self, prediction) -> np.ndarray:
        s = self.intercept + self.slope * np.abs(np.asarray(prediction, dtype=float))
        # a zero intercept would give a zero-width interval at ŷ = 0: keep s a millionth of its size at |ŷ| = 1
        return np.maximum(s, 1e-6 * (self.intercept + self.slope))

    @classmethod
    def fit(cls, prediction, absolute_residual) -> "ScoreScale":
        """Non-negative least squares of |y − ŷ| on [1, |ŷ|]; (1, 0) if the residuals are all 0."""
        from scipy.optimize import nnls

        design = np.column_stack([np.ones(len(prediction)), np.abs(np.asarray(prediction, dtype=float))])
        (intercept, slope), _ = nnls(design, np.asarray(absolute_residual, dtype=float))
        return cls(float(intercept), float(slope)) if intercept + slope > 0 else cls()


@dataclass(frozen=True)
class BinnedScale:
    """The difficulty model s(ŷ) of the ``binned`` score: the mean absolute residual of the runs
    whose out-of-fold ŷ fell in the same bin (quantile bins of ŷ, ``edges`` between them), at least
    ``SCALE_FLOOR`` times the median absolute residual (units of y)."""

    edges: tuple[float, ...]
    values: tuple[float, ...]

    def __post_init__(self):
        if len(self.values) != len(self.edges) + 1 or not all(math.isfinite(v) and v > 0 for v in self.values):
            raise ValueError(f"binned scale: {len(self.values)} values for {len(self.edges)} edges; "
                             "need one more value than edges, each a finite number > 0")
        if list(self.edges) != sorted(self.edges):
            raise ValueError("binned scale: edges must be increasing")

    def __call__(self, prediction) -> np.ndarray:
        return np.asarray(self.values)[np.searchsorted(self.edges, np.asarray(prediction, dtype=float), side="right")]

    @classmethod
    def fit(cls, prediction, absolute_residual) -> tuple["BinnedScale | ScoreScale", np.ndarray]:
        """The scale and, for each run, its scale left out of its own bin's mean (leave-one-out, so that
        a run's score does not shrink by its own residual); the absolute scale if the residuals are all 0."""
        y_hat = np.asarray(prediction, dtype=float)
        r = np.asarray(absolute_residual, dtype=float)
        floor = SCALE_FLOOR * float(np.median(r))
        if floor == 0.0:
            return ScoreScale(), np.ones(len(r))
        bins = max(1, min(SCORE_BINS, len(r) // 4))
        edges = np.quantile(y_hat, np.linspace(0.0, 1.0, bins + 1)[1:-1])
        which = np.searchsorted(edges, y_hat, side="right")
        sums, counts = np.bincount(which, r, bins), np.bincount(which, minlength=bins)
        means = np.where(counts > 0, sums / np.maximum(counts, 1), float(r.mean()))
        left_out = np.where(counts[which] > 1, (sums[which] - r) / np.maximum(counts[which] - 1, 1), means[which])
        scale = cls(tuple(float(e) for e in edges), tuple(float(v) for v in np.maximum(means, floor)))
        return scale, np.maximum(left_out, floor)


def check_confidence(confidence: float) -> float:
    """``confidence`` as a float in the open interval (0, 1), else a one-line ValueError."""
    try:
        c = float(confidence)
    except (TypeError, ValueError):
        raise ValueError(f"confidence = {confidence!r}: must be a number in (0, 1), e.g. 0.9") from None
    if not 0.0 < c < 1.0:
        raise ValueError(f"confidence = {confidence!r}: must be in the open interval (0, 1), e.g. 0.9")
    return c


def conformal_rank(n: int, confidence: float) -> int:
    """The finite-sample rank ⌈c·(n+1)⌉ (1-based) of the calibration quantile among n residuals."""
    c = check_confidence(confidence)
    return math.ceil(c * (n + 1) - 1e-12)  # 1e-12: 0.9·(9+1) must be 9, not 10 from round-off


def residual_quantile(residuals, confidence: float) -> float:
    """q = the ⌈c·(n+1)⌉-th smallest residual (units of y); ``inf`` when that rank exceeds n.

    An infinite q means there are too few runs for that confidence (n < c/(1 − c)): the honest
    interval is unbounded.
    """
    r = np.sort(np.asarray(residuals, dtype=float))
    if r.ndim != 1 or len(r) == 0 or not np.all(np.isfinite(r)):
        raise ValueError("residuals must be a non-empty 1-D array of finite numbers")
    k = conformal_rank(len(r), confidence)
    return float(r[k - 1]) if k <= len(r) else math.inf


def _as_2d(X):
    return X if hasattr(X, "iloc") else np.asarray(X, dtype=float).reshape(len(X), -1)


def _rows(X, idx):
    return X.iloc[idx] if hasattr(X, "iloc") else X[idx]


@dataclass
class ConformalRegressor:
    """Cross-conformal prediction intervals around any ``make_estimator()`` regressor.

    ``make_estimator``: a zero-argument factory of unfitted regressors (``fit(X, y)``,
    ``predict(X)``), e.g. ``functools.partial(RandomForestRegressor, n_estimators=146)``.
    ``folds``: K ≥ 2 of the out-of-fold residuals (10 in dsmv-train). ``confidence``: c in (0, 1),
    the target coverage. ``method``: ``pooled``, ``oob`` or ``cv_plus``; ``score``: ``absolute``
    or ``scaled`` (module docstring).
    """

    make_estimator: Callable
    folds: int = 10
    confidence: float = 0.9
    method: Literal["pooled", "cv_plus", "oob"] = "pooled"
    seed: int = 0
    score: Literal["absolute", "scaled", "binned"] = "absolute"
    estimator_: object = field(default=None, init=False, repr=False)
    fold_models_: list = field(default_factory=list, init=False, repr=False)
    fold_of_: np.ndarray | None = field(default=None, init=False, repr=False)
    residuals_: np.ndarray | None = field(default=None, init=False, repr=False)  # scores R_i (units of y / scale)
    scale_: ScoreScale | BinnedScale = field(default_factory=ScoreScale, init=False, repr=False)  # s(ŷ), fitted

    def __post_init__(self):
        self.confidence = check_confidence(self.confidence)
        if not isinstance(self.folds, (int, np.integer)) or self.folds < 2:
            raise ValueError(f"folds = {self.folds!r}: must be an integer ≥ 2")
        if self.method not in METHODS:
            raise ValueError(f"method = {self.method!r}: must be one of {', '.join(METHODS)}")
        if self.score not in SCORES:
            raise ValueError(f"score = {self.score!r}: must be one of {', '.join(SCORES)}")

    def fit(self, X, y) -> "ConformalRegressor":
        """Fit K fold models (out-of-fold residuals) and the full-data model."""
        from sklearn.model_selection import KFold

        X = _as_2d(X)
        y = np.asarray(y, dtype=float)
        if y.ndim != 1 or len(y) != len(X):
            raise ValueError(f"y must be 1-D with one value per row of X: {len(X)} rows, y of shape {y.shape}")
        if len(y) < self.folds:
            raise ValueError(f"{len(y)} rows cannot make {self.folds} folds")
        if self.method == "oob":  # one bagged fit: every run's residual from the trees that never saw it
            model = self.make_estimator()
            if "oob_score" not in model.get_params():
                raise ValueError(f"method 'oob' needs a bagged estimator with oob_score; {type(model).__name__} has none")
            self.estimator_ = model.set_params(oob_score=True, bootstrap=True).fit(X, y)
            self._calibrate(y, np.asarray(self.estimator_.oob_prediction_, dtype=float))
            self.fold_models_, self.fold_of_ = [], None
            return self
        self.fold_of_ = np.empty(len(y), dtype=int)
        out_of_fold = np.empty(len(y))
        self.fold_models_ = []
        for k, (train, held) in enumerate(KFold(self.folds, shuffle=True, random_state=self.seed).split(X)):
            model = self.make_estimator().fit(_rows(X, train), y[train])
            self.fold_models_.append(model)
            self.fold_of_[held] = k
            out_of_fold[held] = np.asarray(model.predict(_rows(X, held)), dtype=float)
        self._calibrate(y, out_of_fold)
        self.estimator_ = self.make_estimator().fit(X, y)
        return self

    def _calibrate(self, y, out_of_fold):
        """Scores from out-of-fold (or out-of-bag) predictions; fits s(ŷ) first for ``scaled`` and
        ``binned`` (whose runs are scored with their own residual left out of their bin's scale)."""
        absolute = np.abs(y - out_of_fold)
        if self.score == "binned":
            self.scale_, own = BinnedScale.fit(out_of_fold, absolute)
            self.residuals_ = absolute / own
            return
        self.scale_ = ScoreScale.fit(out_of_fold, absolute) if self.score == "scaled" else ScoreScale()
        self.residuals_ = absolute / self.scale_(out_of_fold)

    @property
    def quantile_(self) -> float:
        """The pooled score quantile q at ``confidence`` (units of y for the absolute score)."""
        self._check_fitted()
        return residual_quantile(self.residuals_, self.confidence)

    def _check_fitted(self):
        if self.residuals_ is None:
            raise ValueError("ConformalRegressor is not fitted: call fit(X, y) first")

    def predict(self, X, confidence: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(mid, lower, upper), each of shape (len(X),), in units of y."""
        self._check_fitted()
        c = self.confidence if confidence is None else check_confidence(confidence)
        X = _as_2d(X)
        mid = np.asarray(self.estimator_.predict(X), dtype=float)
        if self.method in ("pooled", "oob"):
            half = residual_quantile(self.residuals_, c) * self.scale_(mid)
            return mid, mid - half, mid + half
        # CV+: for each test row, n lower and n upper candidates, one per calibration run
        fold_pred = np.stack([np.asarray(m.predict(X), dtype=float) for m in self.fold_models_])  # (K, m)
        centres = fold_pred[self.fold_of_]  # (n, m): μ₋ₖ₍ᵢ₎(x) for every run i
        n = len(self.residuals_)
        k = conformal_rank(n, c)
        if k > n:
            inf = np.full_like(mid, math.inf)
            return mid, -inf, inf
        r = self.residuals_[:, None] * self.scale_(centres)
        upper = np.sort(centres + r, axis=0)[k - 1]
        lower = -np.sort(-(centres - r), axis=0)[k - 1]
        return mid, lower, upper


def calibration_record(model: ConformalRegressor, target: str, confidences=(0.8, 0.9, 0.95)) -> dict:
    """What a trained surrogate carries for its intervals (``conformal.json``, see dsmv-predict).

    ``residuals`` are the n out-of-fold scores: absolute residuals in the units of ``target``
    (``z_over_b``: dimensionless z/B), or for ``score = scaled`` residuals divided by
    ``scale_intercept + scale_slope·|ŷ|`` (intercept in the target's units), so any confidence
    can be served; ``quantiles`` are a convenience for people reading the file.
    """
    model._check_fitted()
    method = "out_of_bag_pooled" if model.method == "oob" else "cross_conformal_pooled"
    scale = model.scale_
    if isinstance(scale, BinnedScale):
        shape = {"scale_edges": list(scale.edges), "scale_values": list(scale.values)}
    else:
        shape = {"scale_intercept": scale.intercept, "scale_slope": scale.slope}
    return {"method": method, "target": target, "folds": int(model.folds), "seed": int(model.seed),
            "score": model.score, **shape,
            "n": int(len(model.residuals_)), "residuals": [float(r) for r in model.residuals_],
            "quantiles": {f"{c:g}": residual_quantile(model.residuals_, c) for c in confidences}}


def binomial_band(confidence: float, n: int, level: float = 0.95) -> tuple[float, float]:
    """The central ``level`` range of the observed coverage k/n when k ~ Binomial(n, c).

    ``[F⁻¹((1 − level)/2), F⁻¹((1 + level)/2)] / n`` with F the Binomial(n, c) CDF
    (≈ c ± 1.96·√(c·(1 − c)/n) for level 0.95).
    """
    from scipy.stats import binom

    c = check_confidence(confidence)
    lo, hi = binom.interval(level, int(n), c)
    return float(lo / n), float(hi / n)


@dataclass(frozen=True)
class Coverage:
    """Coverage of the intervals over Monte Carlo re-splits."""

    mean: float  # mean over splits of the covered fraction of the test rows (-)
    per_split: np.ndarray  # covered fraction of each split's test rows (-)
    band: tuple[float, float]  # 95 % binomial range of ``mean`` if the true coverage is c (-)
    mean_width: float  # mean interval width (units of y)
    n_distinct: int  # rows that were in at least one test set (-): the band's n
    by_tercile: tuple[float, float, float] = (math.nan,) * 3  # coverage where ŷ is in the low/middle/high third of y (-)

    def __iter__(self):  # (mean, per_split, band): unpacks as a tuple
        return iter((self.mean, self.per_split, self.band))


def coverage_over_resplits(make_estimator: Callable, X, y, n_splits: int = 200, test_fraction: float = 0.1,
                           confidence: float = 0.9, seed: int = 0, folds: int = 10,
                           method: str = "pooled", score: str = "absolute") -> Coverage:
    """Refit a :class:`ConformalRegressor` on ``n_splits`` random splits; measure test coverage.

    Split i uses :func:`dsmv.surrogate.evaluate.split` with seed ``seed + i`` (the same splits as
    dsmv-train's Monte Carlo scores). The band: the mean over re-splits averages
    ``n_splits·n_test`` indicators, but re-splits of one dataset reuse its rows, so those are
    not independent. Its spread is that of one pass over the distinct rows tested, N ≈ n
    (all rows after ~50 splits of 10 %); hence
    ``band = binomial_band(confidence, N)`` = the 2.5 % and 97.5 % quantiles of Binomial(N, c) / N.
    (Taking ``n_splits·n_test`` as N would make the band √(n_splits·test_fraction) ≈ 4.5 times
    too narrow and fail calibrated models.) ``by_tercile``: the covered fraction of the test
    predictions whose ŷ lies in the lower, middle and upper third of the dataset's y (grouping
    by ŷ, what a user sees, not by the true y: selecting rows by y selects their noise too).
    """
    c = check_confidence(confidence)
    if n_splits < 1:
        raise ValueError(f"n_splits = {n_splits!r}: must be ≥ 1")
    if not 0.0 < test_fraction < 1.0:
        raise ValueError(f"test_fraction = {test_fraction!r}: must be in (0, 1)")
    X = _as_2d(X)
    y = np.asarray(y, dtype=float)
    covered, widths = np.empty(n_splits), np.empty(n_splits)
    seen = np.zeros(len(y), dtype=bool)
    thirds = np.quantile(y, [1 / 3, 2 / 3])
    hits, tests = np.zeros(3), np.zeros(3)
    for i in range(n_splits):
        train, test = split(len(y), test_fraction, seed + i)
        model = ConformalRegressor(make_estimator, folds, c, method, seed + i, score).fit(_rows(X, train), y[train])
        mid, lower, upper = model.predict(_rows(X, test))
        inside = (y[test] >= lower) & (y[test] <= upper)
        tercile = np.searchsorted(thirds, mid, side="right")  # 0, 1, 2 per test row
        covered[i] = np.mean(inside)
        np.add.at(hits, tercile, inside)
        np.add.at(tests, tercile, 1.0)
        widths[i] = np.mean(upper - lower)
        seen[test] = True
    n_distinct = int(seen.sum())
    by_tercile = tuple(float(h / t) if t else math.nan for h, t in zip(hits, tests))
    return Coverage(float(covered.mean()), covered, binomial_band(c, n_distinct), float(widths.mean()), n_distinct,
                    by_tercile)


__all__ = ["ConformalRegressor", "Coverage", "coverage_over_resplits", "binomial_band", "residual_quantile",
           "conformal_rank", "check_confidence", "calibration_record", "ScoreScale",
           "METHODS", "SCORES"]
