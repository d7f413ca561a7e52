"""The fast models corrected by the CEL, round by round (``calibrate.cel_corrections``).

A fit by the fast test models carries their error against the CEL: on a site measured on the CEL the
cycles' softening (+5 % at the tenth) and the T-bar's rate gain (2 % less over two decades) took the
sensitivity 5–12 % and η 14–22 % low (docs, site tests). A round of correction measures every test on
the CEL at the fit θ_k, each on its own design (:func:`dsmv.calibration.cel_tests.measure`), and multiplies
each row's model value by the CEL's over the model's there,

    c_i = CEL_i(θ_k) / model_i(θ_k),

then fits the corrected model c·model(θ) again: θ_{k+1}. This is defect correction, the simplest form
of space mapping. If the data are the CEL's at some θ*, then θ* is a fixed point: there the corrected
model is the CEL. The rounds contract as fast as the models' error against the CEL changes with θ,
compared with how fast the models themselves change. With scatter in the data the fixed point is the
corrected models' least-squares fit (their Jacobian's normal equations), not the CEL's own; the
bootstrap's intervals take the factors as exact. A row the CEL did not read (a profile's rows
shallower than where its push is steady) borrows the factor of the nearest row it did read at the
same rate; a rate or a cyclic test it read nothing of keeps the models' value, and is reported.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Callable

import numpy as np

from dsmv.calibration.data import SiteTest
from dsmv.calibration.fit import Problem, best_fit

#: measures a test's design at a soil in a round, returning the rows it read (its measured quantity, SI)
Measure = Callable[[SiteTest, object, int], SiteTest]


def row_factors(test: SiteTest, read: SiteTest, factors: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The factors of ``read``'s rows carried onto ``test``'s, and which rows got one: a T-bar's row takes
    the factor of the read row at its rate (within 1e-6) nearest in cycle, then in depth; a cone's, the
    read cone nearest in its sample's depth, then in mass. A rate the CEL did not read keeps 1 and is
    reported uncorrected: the factors change with the rate, which is what they correct."""
    out, matched = np.ones(len(test)), np.zeros(len(test), bool)
    if len(read) == 0:
        return out, matched
    c, r = test.columns, read.columns
    for i in range(len(test)):
        if test.kind == "tbar":
            candidates = np.flatnonzero(np.isclose(r["velocity"], c["velocity"][i], rtol=1e-6, atol=0.0))
            keys = (np.abs(r["cycle"] - c["cycle"][i]), np.abs(r["depth"] - c["depth"][i]))
        else:
            candidates = np.arange(len(read))
            keys = (np.abs(r["sample_depth"] - c["sample_depth"][i]), np.abs(r["mass"] - c["mass"][i]))
        if len(candidates):
            nearest = candidates[np.lexsort(tuple(k[candidates] for k in reversed(keys)))[0]]
            out[i], matched[i] = factors[nearest], True
    return out, matched


def discrepancy(problem: Problem, values, measure: Measure, round_: int = 1) -> tuple[list[np.ndarray], list[dict]]:
    """Each test measured at ``values`` by ``measure`` (in round ``round_``): its rows' factors, the CEL's
    over the models' alone, and per test the rows corrected and the factors' range. A row the CEL read
    with no positive finite value counts as not read."""
    soil = problem.soil_at(values)
    factors, summary = [], []
    for test in problem.tests:
        read = measure(test, soil, round_)
        ratio = read.measured / problem.predict(values, [read], corrected=False)[0] if len(read) else np.empty(0)
        good = np.isfinite(ratio) & (ratio > 0)
        read = read.rows(good)
        row, matched = row_factors(test, read, ratio[good])
        factors.append(row)
        summary.append({"test": test.name, "rows": len(test), "rows_read": len(read),
                        "rows_corrected": int(matched.sum()), "factors": [float(f) for f in row],
                        "cel_over_model_min": float(row[matched].min()) if matched.any() else float("nan"),
                        "cel_over_model_max": float(row[matched].max()) if matched.any() else float("nan")})
    return factors, summary


def relative_move(before: float, after: float) -> float:
    """after/before − 1, the move of a value that was 0 its absolute change."""
    return float(after / before - 1.0) if before else float(after - before)


def corrected(problem: Problem, rounds: int, measure: Measure,
              said: Callable[[str], None] = lambda line: None) -> tuple[Problem, list[dict]]:
    """``rounds`` rounds of correction from the models' own fit: the corrected problem (its correction
    that of the last round's fit) and each round's record (where it measured, the factors, the refit)."""
    best = best_fit(problem)
    history = []
    for k in range(1, rounds + 1):
        said(f"  CEL correction {k}/{rounds}: every test on the CEL at "
             + ", ".join(f"{key} = {v:.4g}" for key, v in zip(problem.keys, best)))
        factors, summary = discrepancy(problem, best, measure, k)
        problem = replace(problem, correction=factors)
        refit = best_fit(problem)
        history.append({"round": k, "measured_at": dict(zip(problem.keys, map(float, best))), "tests": summary,
                        "refit": dict(zip(problem.keys, map(float, refit))),
                        "moved": {key: relative_move(a, b) for key, a, b in zip(problem.keys, best, refit)}})
        said("    refit moved " + ", ".join(f"{key} {m:+.1%}" for key, m in history[-1]["moved"].items()))
        best = refit
    return problem, history


__all__ = ["corrected", "discrepancy", "row_factors", "relative_move", "Measure"]
