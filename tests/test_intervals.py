"""Cross-conformal intervals (dsmv.surrogate.intervals) and the inverse solve (dsmv.surrogate.inverse).

Synthetic data y = f(x) + N(0, σ) with a known f, fitted by least squares on the right basis:
the exact half-width of a 90 % interval is z₀.₉₅·σ = 1.645·σ, and the coverage of calibrated
intervals must lie in the binomial band.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from sklearn.linear_model import LinearRegression

from dsmv.surrogate.intervals import (ConformalRegressor, binomial_band, calibration_record, conformal_rank,
                                      coverage_over_resplits, residual_quantile)
from dsmv.surrogate.inverse import InverseError, solve_inverse

Z95 = 1.6448536269514722  # standard normal 95 % quantile: the 90 % two-sided half-width / σ


def synthetic(n: int, sigma: float, seed: int = 0):
    """x in [0, 1]², y = 1 + 2·x₀ − 3·x₁ + N(0, σ)."""
    rng = np.random.default_rng(seed)
    X = rng.uniform(0.0, 1.0, size=(n, 2))
    return X, 1.0 + 2.0 * X[:, 0] - 3.0 * X[:, 1] + rng.normal(0.0, sigma, n)


@pytest.mark.parametrize("method", ["pooled", "cv_plus"])
def test_coverage_of_90_percent_intervals_lies_in_the_binomial_band(method):
    X, y = synthetic(300, sigma=0.2, seed=1)
    cov = coverage_over_resplits(LinearRegression, X, y, n_splits=40, test_fraction=0.1, confidence=0.9,
                                 seed=0, folds=5, method=method)
    mean, per_split, band = cov
    assert per_split.shape == (40,)
    assert cov.n_distinct > 250
    assert band[0] < 0.9 < band[1] and band[1] - band[0] < 0.08  # N ≈ 290: ±3.5 %
    assert band[0] <= mean <= band[1], (method, mean, band)
    assert cov.mean_width == pytest.approx(2 * Z95 * 0.2, rel=0.15)


def test_binomial_band_formula():
    lo, hi = binomial_band(0.9, 257)
    assert lo == pytest.approx(0.9 - 1.96 * math.sqrt(0.09 / 257), abs=0.005)
    assert hi == pytest.approx(0.9 + 1.96 * math.sqrt(0.09 / 257), abs=0.005)


def test_intervals_widen_with_noise_as_the_normal_quantile():
    widths = {}
    for sigma in (0.05, 0.5):
        X, y = synthetic(400, sigma, seed=2)
        model = ConformalRegressor(LinearRegression, folds=5, confidence=0.9).fit(X, y)
        mid, lower, upper = model.predict(X[:7])
        assert mid.shape == lower.shape == upper.shape == (7,)
        assert np.all(lower < mid) and np.all(mid < upper)
        widths[sigma] = float(np.mean(upper - lower))
        assert widths[sigma] / 2 == pytest.approx(Z95 * sigma, rel=0.15)
    assert widths[0.5] / widths[0.05] == pytest.approx(10.0, rel=0.25)


def test_rank_and_quantile_are_the_finite_sample_ones():
    assert conformal_rank(9, 0.9) == 9  # ⌈0.9·10⌉
    assert conformal_rank(257, 0.9) == 233  # ⌈0.9·258⌉ = ⌈232.2⌉
    assert residual_quantile(np.arange(1.0, 10.0), 0.9) == 9.0
    assert residual_quantile(np.arange(1.0, 5.0), 0.9) == math.inf  # 4 runs cannot give 90 %


def test_calibration_record_serves_any_confidence():
    X, y = synthetic(60, 0.1)
    model = ConformalRegressor(LinearRegression, folds=5).fit(X, y)
    record = calibration_record(model, "z_over_b")
    assert record["n"] == 60 and len(record["residuals"]) == 60
    assert record["quantiles"]["0.9"] == pytest.approx(model.quantile_)
    assert residual_quantile(record["residuals"], 0.9) == model.quantile_


@pytest.mark.parametrize("confidence", [0.0, 1.0, 1.5, -0.1, "high", None])
def test_confidence_outside_the_open_unit_interval_is_a_clear_value_error(confidence):
    with pytest.raises(ValueError, match=r"confidence = .*: must be"):
        ConformalRegressor(LinearRegression, confidence=confidence)
    X, y = synthetic(40, 0.1)
    with pytest.raises(ValueError, match=r"confidence"):
        coverage_over_resplits(LinearRegression, X, y, n_splits=2, confidence=confidence, folds=3)


def test_bad_input_errors():
    X, y = synthetic(20, 0.1)
    with pytest.raises(ValueError, match="folds"):
        ConformalRegressor(LinearRegression, folds=1)
    with pytest.raises(ValueError, match="not fitted"):
        ConformalRegressor(LinearRegression).predict(X)
    with pytest.raises(ValueError, match="one value per row"):
        ConformalRegressor(LinearRegression, folds=3).fit(X, y[:-1])
    with pytest.raises(ValueError, match="method"):
        ConformalRegressor(LinearRegression, method="split")


# ------------------------------------------------------------------------------ inverse


def quadratic_upper(a: float = 0.1, c: float = 0.05, column: str = "velocity_m_s"):
    """upper(v) = c + a·v² (m): monotone increasing, exact answer v* = √((limit − c)/a)."""
    return lambda table: c + a * table[column].to_numpy(float) ** 2


BASE = {"velocity_m_s": 1.5, "contact_length_m": 4.17, "su0_pa": 1000.0}


def test_max_velocity_matches_the_exact_root():
    result = solve_inverse(quadratic_upper(), BASE, "landing.velocity_m_s", (0.1, 3.0), 0.3)
    exact = math.sqrt((0.3 - 0.05) / 0.1)  # 1.5811 m/s
    assert result.status == "ok" and result.monotone
    assert result.value == pytest.approx(exact, abs=1e-6)
    assert result.upper_at_value <= 0.3


def test_min_contact_length_matches_the_exact_root():
    upper = lambda t: 1.2 / t["contact_length_m"].to_numpy(float)  # noqa: E731  z ∝ 1/L: L* = 1.2/limit
    result = solve_inverse(upper, BASE, "geometry.contact_length_m", (2.0, 6.0), 0.3)
    assert result.status == "ok" and result.value == pytest.approx(4.0, abs=1e-6)


def test_range_ends_are_reported():
    all_pass = solve_inverse(quadratic_upper(), BASE, "landing.velocity_m_s", (0.1, 1.0), 0.3)
    assert all_pass.status == "whole_range_passes" and all_pass.value == 1.0
    none = solve_inverse(quadratic_upper(c=0.4), BASE, "landing.velocity_m_s", (0.1, 3.0), 0.3)
    assert none.status == "no_value_passes" and math.isnan(none.value)


def test_non_monotone_prediction_gives_the_conservative_answer():
    # passes below 1.0, fails on (1.0, 1.2), passes again on [1.2, 1.6], fails above: answer 1.0, flagged
    def upper(t):
        v = t["velocity_m_s"].to_numpy(float)
        return np.where(v < 1.0, 0.1, np.where(v < 1.2, 0.5, np.where(v <= 1.6, 0.2, 0.5)))

    result = solve_inverse(upper, BASE, "landing.velocity_m_s", (0.0, 3.0), 0.3, points=31)
    assert not result.monotone and result.status == "ok"
    assert result.value == pytest.approx(1.0, abs=1e-6)


def test_inverse_errors():
    with pytest.raises(InverseError, match="sinkage_limit_m"):
        solve_inverse(quadratic_upper(), BASE, "landing.velocity_m_s", (0.1, 3.0), 0.0)
    with pytest.raises(InverseError, match="parameter"):
        solve_inverse(quadratic_upper(), BASE, "soil.su0_pa", (0.1, 3.0), 0.3)
    with pytest.raises(InverseError, match="range"):
        solve_inverse(quadratic_upper(), BASE, "landing.velocity_m_s", (3.0, 0.1), 0.3)


def test_out_of_bag_intervals_cover_as_asked_with_one_fit_per_split():
    """A random forest's out-of-bag residuals calibrate 90 % intervals on a noisy linear truth:
    mean coverage over re-splits inside the binomial band, half-width about 1.645·σ."""
    import functools

    from sklearn.ensemble import RandomForestRegressor

    from dsmv.surrogate.intervals import ConformalRegressor, coverage_over_resplits

    rng = np.random.default_rng(3)
    X = rng.uniform(0, 1, (300, 2))
    sigma = 0.1
    y = 2 * X[:, 0] + X[:, 1] + rng.normal(0, sigma, 300)
    make = functools.partial(RandomForestRegressor, n_estimators=60, min_samples_leaf=3, random_state=0)
    coverage = coverage_over_resplits(make, X, y, n_splits=20, test_fraction=0.1, confidence=0.9, method="oob")
    assert coverage.band[0] <= coverage.mean <= coverage.band[1]
    model = ConformalRegressor(make, method="oob").fit(X, y)
    assert model.quantile_ == pytest.approx(1.645 * sigma, rel=0.35)
    with pytest.raises(ValueError, match="oob_score"):
        from sklearn.linear_model import LinearRegression

        ConformalRegressor(LinearRegression, method="oob").fit(X, y)


def heteroscedastic(n: int, seed: int = 0):
    """y = x·(1 + N(0, 0.2)), x ~ U(0.1, 1): the scatter grows in proportion to y, as sinkage's does."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(0.1, 1.0, size=(n, 1))
    return x, x[:, 0] * (1.0 + rng.normal(0.0, 0.2, n))


def test_scaled_score_fits_the_difficulty_model_and_widens_with_the_prediction():
    X, y = heteroscedastic(400, seed=3)
    model = ConformalRegressor(LinearRegression, folds=5, confidence=0.9, score="scaled").fit(X, y)
    # exact: |y − x| = 0.2·x·|N(0, 1)|, mean 0.2·√(2/π)·x: intercept 0, slope 0.160
    assert model.scale_.slope == pytest.approx(0.2 * math.sqrt(2 / math.pi), rel=0.15)
    assert model.scale_.intercept < 0.1 * model.scale_.slope
    mid, lower, upper = model.predict(np.array([[0.2], [0.8]]))
    width = upper - lower
    assert width[1] / width[0] == pytest.approx(mid[1] / mid[0], rel=0.15)
    assert width / 2 == pytest.approx(Z95 * 0.2 * mid, rel=0.2)  # the exact 90 % half-width: 1.645·0.2·x
    record = calibration_record(model, "z_over_b")
    assert record["score"] == "scaled"
    assert (record["scale_intercept"], record["scale_slope"]) == (model.scale_.intercept, model.scale_.slope)


def test_scaled_score_covers_the_deep_end_where_the_absolute_one_does_not():
    """Same data, same learner: the absolute score undercovers where the prediction is in the
    largest third of y (the errors are largest there) and overcovers the smallest third; the
    scaled one covers every third within its binomial band."""
    X, y = heteroscedastic(600, seed=4)
    absolute = coverage_over_resplits(LinearRegression, X, y, n_splits=40, confidence=0.9, folds=5)
    scaled = coverage_over_resplits(LinearRegression, X, y, n_splits=40, confidence=0.9, folds=5, score="scaled")
    band = binomial_band(0.9, scaled.n_distinct // 3)  # one third of the distinct rows
    assert absolute.by_tercile[2] < band[0], absolute.by_tercile
    assert absolute.by_tercile[0] > band[1], absolute.by_tercile
    assert all(band[0] <= c <= band[1] for c in scaled.by_tercile), (scaled.by_tercile, band)
    assert scaled.band[0] <= scaled.mean <= scaled.band[1]


def test_scale_model_and_bad_score_settings():
    from dsmv.surrogate.intervals import ScoreScale

    assert ScoreScale.fit(np.array([1.0, 2.0, 3.0]), np.zeros(3)) == ScoreScale()  # a perfect fit: absolute
    flat = ScoreScale.fit(np.array([1.0, 2.0]), np.array([0.5, 0.5]))  # residuals independent of ŷ
    assert (flat.intercept, flat.slope) == pytest.approx((0.5, 0.0))
    assert ScoreScale(0.0, 2.0)(np.array([0.0, -1.0])) == pytest.approx([2e-6, 2.0])  # never zero width
    with pytest.raises(ValueError, match="score"):
        ConformalRegressor(LinearRegression, score="quantile")
    with pytest.raises(ValueError, match="both 0"):
        ScoreScale(0.0, 0.0)
    with pytest.raises(ValueError, match="slope"):
        ScoreScale(1.0, -0.1)


def hump(n: int, seed: int):
    """y = x + noise whose σ peaks mid-range (0.02 + 0.3·x·(1 − x)): not linear in ŷ."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(0.0, 1.0, n)
    return x.reshape(-1, 1), x + (0.02 + 0.3 * x * (1.0 - x)) * rng.normal(size=n)


def test_binned_score_covers_every_third_where_a_line_in_y_hat_cannot():
    """Errors largest in the middle of the range: the scaled score (a + b·ŷ) undercovers the middle
    third and overcovers an end; the binned one covers every third within its binomial band."""
    X, y = hump(600, seed=6)
    scaled = coverage_over_resplits(LinearRegression, X, y, n_splits=40, confidence=0.9, folds=5, score="scaled")
    binned = coverage_over_resplits(LinearRegression, X, y, n_splits=40, confidence=0.9, folds=5, score="binned")
    band = binomial_band(0.9, binned.n_distinct // 3)
    assert scaled.by_tercile[1] < band[0] and max(scaled.by_tercile[0], scaled.by_tercile[2]) > band[1], scaled.by_tercile
    assert all(band[0] <= c <= band[1] for c in binned.by_tercile), (binned.by_tercile, band)


def test_binned_scale_by_hand_and_its_record():
    """Eight runs, two bins at the median of ŷ: each bin's mean residual, and each run scored by its
    bin's mean without itself; the record serves the same interval the regressor does."""
    from dsmv.surrogate.intervals import BinnedScale
    from dsmv.surrogate.predictor import Calibration

    y_hat = np.array([1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0])
    r = np.array([0.1, 0.3, 0.2, 0.2, 1.0, 2.0, 3.0, 2.0])
    scale, own = BinnedScale.fit(y_hat, r)
    assert scale.edges == (4.5,) and scale.values == pytest.approx((0.2, 2.0))
    assert own == pytest.approx([0.7 / 3, 0.5 / 3, 0.6 / 3, 0.6 / 3, 7.0 / 3, 6.0 / 3, 5.0 / 3, 6.0 / 3])
    assert scale(np.array([0.0, 4.5, 100.0])) == pytest.approx([0.2, 2.0, 2.0])
    floored, _ = BinnedScale.fit(y_hat, np.array([0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0]))
    assert floored.values == pytest.approx((0.05, 1.0))  # 0.1 × the median residual 0.5

    X, y = hump(200, seed=2)
    model = ConformalRegressor(LinearRegression, folds=5, confidence=0.9, score="binned").fit(X, y)
    record = calibration_record(model, "z_over_b")
    assert record["score"] == "binned" and len(record["scale_values"]) == len(record["scale_edges"]) + 1 == 8
    served = Calibration.from_record(record, "test")
    import pandas as pd

    rows = np.array([[0.1], [0.5], [0.9]])
    mid, lower, upper = model.predict(rows)
    half = served.half_width_m(pd.DataFrame({"width_m": [1.0, 1.0, 1.0]}), mid, 0.9)
    assert half == pytest.approx((upper - lower) / 2, rel=1e-12)


def test_auto_bins_the_scores_once_the_training_runs_fill_each_bin():
    """train.interval_score=auto: scaled below 8 runs a bin (64 training runs), binned from there on;
    an explicit score is kept whatever the size."""
    from dsmv.surrogate.intervals import SCORE_BINS
    from dsmv.surrogate.train import BINNED_RUNS_PER_BIN, TrainSettings, interval_score

    settings = TrainSettings.model_construct(interval_score="auto")
    limit = SCORE_BINS * BINNED_RUNS_PER_BIN
    assert limit == 64
    assert interval_score(limit - 1, settings) == "scaled" and interval_score(limit, settings) == "binned"
    assert interval_score(10, TrainSettings.model_construct(interval_score="binned")) == "binned"
