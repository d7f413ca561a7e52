"""The fast models corrected by the CEL, round by round (``calibrate.cel_corrections``).

A fit by the fast test models carries their error against the CEL: on a site measured on the CEL the
cycles' softening (+5 % at the tenth) and the T-bar's rate gain (2 % less over two decades) took the
sensitivity 5–12 % and η 14–22 % low (docs, site tests). A round of correction measures every test on
the CEL at the fit θ_k, each on its own design (:func:`dsmv.calibration.cel_site.measure`), and multiplies
each row's model value by the CEL's over the model's there,

    c_i = CEL_i(θ_k) / model_i(θ_k),

then fits the corrected model c·model(θ) again: θ_{k+1}. This is defect correction, the simplest form
of space mapping. If the data are the CEL's at some θ*, then θ* is a fixed point: there the corrected
model is the CEL. The rounds contract as fast as the models' error against the CEL changes with θ,
compared with how fast the models themselves change. A row the CEL did not read (a profile's rows
shallower than where its push is steady, a cycle after an unstable stroke) borrows the factor of the
nearest row it did read at the same rate.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Callable

import numpy as np

from dsmv.calibration.data import SiteTest
from dsmv.calibration.fit import Problem, best_fit

#: measures a test's design at a soil in a round, returning the rows it read (its measured quantity, SI)
Measure = Callable[[SiteTest, object, int], SiteTest]


def row_factors(test: SiteTest, read: SiteTest, factors: np.ndarray) -> np.ndarray:
    """The factors of ``read``'s rows carried onto ``test``'s: each row takes the factor of the read row
    nearest it, a T-bar's at its rate (then its cycle, then its depth), a cone's at its sample's depth
    (then its mass). 1 where nothing was read."""
    out = np.ones(len(test))
    if len(read) == 0:
        return out
    c, r = test.columns, read.columns
    if test.kind == "tbar":
        same, near = ("velocity",), (("cycle", 1.0), ("depth", 1.0 / test.diameter_m))
    else:
        same, near = ("sample_depth",), (("mass", 1.0),)
    for i in range(len(test)):
        candidates = np.flatnonzero(np.all([np.isclose(r[k], c[k][i], rtol=1e-9, atol=0.0) for k in same], axis=0))
        if len(candidates) == 0:
            continue
        distance = [tuple(abs(r[k][j] - c[k][i]) * scale for k, scale in near) for j in candidates]
        out[i] = factors[candidates[min(range(len(candidates)), key=distance.__getitem__)]]
    return out


def discrepancy(problem: Problem, values, measure: Measure, round_: int = 1) -> tuple[list[np.ndarray], list[dict]]:
    """Each test measured at ``values`` by ``measure`` (in round ``round_``): its rows' factors, the CEL's
    over the models' (uncorrected), and a summary of them per test."""
    soil = problem.soil_at(values)
    factors, summary = [], []
    for test in problem.tests:
        read = measure(test, soil, round_)
        ratio = read.measured / problem.predict(values, [read])[0] if len(read) else np.empty(0)
        factors.append(row_factors(test, read, ratio))
        summary.append({"test": test.name, "rows": len(test), "rows_read": len(read),
                        "cel_over_model_min": float(ratio.min()) if len(ratio) else float("nan"),
                        "cel_over_model_max": float(ratio.max()) if len(ratio) else float("nan")})
    return factors, summary


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
                        "moved": {key: float(b / a - 1.0) if a else float("nan")
                                  for key, a, b in zip(problem.keys, best, refit)}})
        said("    refit moved " + ", ".join(f"{key} {m:+.1%}" for key, m in history[-1]["moved"].items()))
        best = refit
    return problem, history


__all__ = ["corrected", "discrepancy", "row_factors", "Measure"]
