"""The inverse design question: how fast may the vehicle land, or how long must its track be,
for the upper bound of the predicted sinkage to stay under a limit?

:func:`solve_inverse` is a pure function of a predictor ``upper(table) -> upper bound of z (m)``
(one value per row of a dataset-style table, :data:`dsmv.surrogate.dataset.PARAMETERS`
columns), a base scene (one row), the parameter to vary, its allowed range and the limit.

Which end is safe: sinkage grows with touchdown velocity and shrinks with contact length, so
``landing.velocity_m_s`` is searched for its *largest* passing value and
``geometry.contact_length_m`` for its *smallest* (:data:`GOALS`). Call the range's end with
the smaller expected sinkage its *safe end* (low velocity, long track).

Algorithm (k-section on a checked grid): evaluate ``points`` values evenly over the range,
walking from the safe end; the answer is bracketed by the last passing value before the first
failing one; the bracket is then subdivided ``points − 1`` ways again (each round shrinks it
by that factor, i.e. ≈ 7 bisections per round at 101 points, in one vectorised model call)
until it is narrower than ``tolerance``. The value returned always passes (the passing side
of the final bracket). A random forest's prediction is piecewise constant, so the answer sits
on one of its steps: that is the model's answer, not a numerical artefact.

Outcomes (:attr:`InverseResult.status`):

``ok``                 the limit is crossed inside the range; ``value`` is the crossing.
``whole_range_passes`` even the unsafe end stays under the limit: ``value`` is that end; the
                       true answer lies beyond the range, where the surrogate has no data.
``no_value_passes``    even the safe end exceeds the limit: ``value`` is NaN (no landing in the
                       range is safe by this model at this confidence).

Monotonicity is checked, not assumed: ``monotone`` is False when the grid's upper bounds ever
decrease walking away from the safe end (a noisy surrogate). The answer is then still the
*first* crossing from the safe end (conservative: a value past a failing stretch is never
returned even if it passes again), and dsmv-predict warns.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Literal

import numpy as np
import pandas as pd

from dsmv.errors import DsmvError
from dsmv.surrogate.dataset import COLUMNS

#: searchable parameter (config key) → goal: the largest (max) or smallest (min) passing value
GOALS: dict[str, Literal["max", "min"]] = {"landing.velocity_m_s": "max", "geometry.contact_length_m": "min"}
#: dsmv-predict task → its parameter
TASK_PARAMETERS = {"max_velocity": "landing.velocity_m_s", "min_contact_length": "geometry.contact_length_m"}


class InverseError(DsmvError):
    """A wrong inverse question (limit, parameter or range): a user mistake, one line."""


@dataclass(frozen=True)
class InverseResult:
    """The answer to the inverse question and the grid it was read from."""

    parameter: str  # config key, e.g. landing.velocity_m_s
    value: float  # the answer (units of the parameter); NaN when no value passes
    status: Literal["ok", "whole_range_passes", "no_value_passes"]
    upper_at_value: float  # upper bound of z at ``value`` (m); NaN when no value passes
    sinkage_limit_m: float  # the limit (m)
    monotone: bool  # grid upper bounds never decrease walking away from the safe end
    grid: np.ndarray  # the checked grid, ascending (units of the parameter)
    grid_upper_m: np.ndarray  # upper bound of z on the grid (m)


def _with(base: pd.DataFrame, column: str, values: np.ndarray) -> pd.DataFrame:
    table = base.loc[base.index.repeat(len(values))].reset_index(drop=True)
    table[column] = values
    return table


def solve_inverse(upper: Callable[[pd.DataFrame], np.ndarray], base, parameter: str, value_range: tuple[float, float],
                  sinkage_limit_m: float, points: int = 101, tolerance: float | None = None) -> InverseResult:
    """The largest velocity (smallest contact length) in ``value_range`` whose upper bound ≤ limit.

    ``upper``: table → upper bound of the sinkage (m) per row. ``base``: the scene as a dict,
    Series or one-row DataFrame of :data:`PARAMETERS` columns. ``parameter``: a key of
    :data:`GOALS`. ``value_range``: (low, high) in the parameter's units. ``sinkage_limit_m``: the
    limit (m) > 0. ``points`` ≥ 3: grid size and subdivisions per round. ``tolerance``: final
    bracket width (parameter units), default 1e-9 of the range.
    """
    if not (isinstance(sinkage_limit_m, (int, float)) and math.isfinite(sinkage_limit_m) and sinkage_limit_m > 0):
        raise InverseError(f"sinkage_limit_m = {sinkage_limit_m!r}: must be a number > 0 (m)")
    if parameter not in GOALS:
        raise InverseError(f"parameter = {parameter!r}: must be one of {', '.join(GOALS)}")
    low, high = (float(v) for v in value_range)
    if not (math.isfinite(low) and math.isfinite(high) and low < high):
        raise InverseError(f"{parameter} range = {list(value_range)!r}: must be [low, high] with low < high")
    if points < 3:
        raise InverseError(f"points = {points!r}: must be ≥ 3")
    column = COLUMNS[parameter]
    if isinstance(base, pd.DataFrame):
        base_table = base.iloc[[0]].reset_index(drop=True)
    else:
        base_table = pd.DataFrame([dict(base)])
    tolerance = 1e-9 * (high - low) if tolerance is None else float(tolerance)

    def evaluate(values):
        return np.asarray(upper(_with(base_table, column, values)), dtype=float)

    grid = np.linspace(low, high, points)
    grid_upper = evaluate(grid)
    # walk from the safe end: low velocity, or long contact length
    order = np.arange(points) if GOALS[parameter] == "max" else np.arange(points)[::-1]
    walk_values, walk_upper = grid[order], grid_upper[order]
    passes = walk_upper <= sinkage_limit_m
    scale = max(float(np.nanmax(np.abs(grid_upper))), 1e-300)
    monotone = bool(np.all(np.diff(walk_upper) >= -1e-12 * scale))

    def result(value, status, upper_value):
        return InverseResult(parameter, float(value), status, float(upper_value), float(sinkage_limit_m), monotone,
                             grid, grid_upper)

    if not passes[0]:
        return result(math.nan, "no_value_passes", math.nan)
    if passes.all():
        return result(walk_values[-1], "whole_range_passes", walk_upper[-1])
    first_fail = int(np.argmin(passes))
    good, bad = walk_values[first_fail - 1], walk_values[first_fail]
    good_upper = walk_upper[first_fail - 1]
    while abs(bad - good) > tolerance:
        values = np.linspace(good, bad, points)[1:-1]  # strictly inside the bracket, from the good side
        ups = evaluate(values)
        fails = ups > sinkage_limit_m
        if not fails.any():
            good, good_upper = values[-1], ups[-1]
            continue
        j = int(np.argmax(fails))
        if j > 0:
            good, good_upper = values[j - 1], ups[j - 1]
        bad = values[j]
    return result(good, "ok", good_upper)


__all__ = ["solve_inverse", "InverseResult", "InverseError", "GOALS", "TASK_PARAMETERS"]
