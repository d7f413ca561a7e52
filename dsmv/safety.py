"""Whether a landing is safe: the run's answers against the limits the user sets (``safety.*``).

A limit left ``null`` is not judged. Each judged answer gets its margin, the limit less the answer
in the limit's unit (negative: exceeded), as a metric ``safety_margin_<what>``; the verdict is the
metric ``safe`` (1 or 0), the summary's ``safety`` line and the MLflow tag ``dsmv.safety``. A body
that cannot turn or slide in its scene (the analytic models, a vertical landing) has turned and
slid 0.
"""

from __future__ import annotations

from typing import Optional

import numpy as np

from dsmv.config.scene import SafetyConfig

#: standard gravity (m/s²): decelerations are quoted in its multiples
G0_M_S2 = 9.80665


#: per limit: what it judges, the metric it reads and its unit
JUDGED = (("max_sinkage_m", "sinkage", "judged_sinkage_m", "m"),
          ("max_tilt_deg", "tilt", "max_rotation_deg", "°"),
          ("max_slide_m", "slide", "max_horizontal_displacement_m", "m"),
          ("max_deceleration_g", "deceleration", "max_deceleration_g", "g"))


def max_deceleration_g(history: dict) -> Optional[float]:
    """How hard the soil stops the body: the largest rate at which its downward speed falls, in g,
    between the time history's samples (each the mean over a stretch of steps: a filter on the
    explicit step's elastic ringing). None without a history; 0 for a body that never slows."""
    if history is None or len(history.get("time_s", ())) < 2:
        return None
    time, speed = np.asarray(history["time_s"], float), np.asarray(history["velocity_m_s"], float)
    step = np.diff(time)
    slowing = -np.diff(speed)[step > 0] / step[step > 0]
    return max(0.0, float(slowing.max(initial=0.0))) / G0_M_S2


def judged(safety: SafetyConfig) -> list[tuple[str, float, str, str]]:
    """The limits set: (what, limit, metric, unit) for each."""
    return [(what, getattr(safety, key), metric, unit) for key, what, metric, unit in JUDGED
            if getattr(safety, key) is not None]


def assess(scene, result, track_sinkage_m: float | None = None) -> None:
    """After a run: a drop's ``max_deceleration_g``, then for each limit set its margin
    (``safety_margin_<what>``, the limit less the answer) and the verdict ``safe`` (1 or 0), into the
    result's metrics. The sinkage judged (``judged_sinkage_m``) is the base's deepest: ``max_sinkage_m``,
    or its lowest point's ``max_edge_sinkage_m`` for a body that may turn; for a track's 2D
    cross-section ``track_sinkage_m``, the most the 3D track sinks by the section's estimate. An answer
    the run does not give (a turn its scene cannot make) is 0; a run that did not end ``ok`` or
    ``bearing_failure`` is not judged, and a bearing failure is unsafe."""
    metrics, units = result.metrics, result.units
    if scene.landing.kind == "drop" and (deceleration := max_deceleration_g(result.history)) is not None:
        metrics["max_deceleration_g"], units["max_deceleration_g"] = deceleration, "g"
    limits = judged(scene.safety)
    if not limits or result.status not in ("ok", "bearing_failure"):
        return
    if "max_sinkage_m" in metrics:  # a body that may turn: its base's lowest point
        deepest = max(metrics["max_sinkage_m"], metrics.get("max_edge_sinkage_m", 0.0))
        metrics["judged_sinkage_m"] = deepest if track_sinkage_m is None else track_sinkage_m
        units["judged_sinkage_m"] = "m"
    for what, limit, metric, unit in limits:
        if metric in metrics or result.status == "ok":
            metrics[f"safety_margin_{what}"] = limit - metrics.get(metric, 0.0)
            units[f"safety_margin_{what}"] = {"°": "deg"}.get(unit, unit)
    exceeded = any(metrics.get(f"safety_margin_{what}", 0.0) < 0 for what, *_ in limits)
    metrics["safe"], units["safe"] = float(result.status == "ok" and not exceeded), "-"


def sinkage_judged(metrics: dict) -> str:
    """Which sinkage the verdict judged, in words, when it is not the middle of the base's."""
    judged = metrics.get("judged_sinkage_m")
    if judged is None or judged == metrics.get("max_sinkage_m"):
        return ""
    if judged == metrics.get("max_edge_sinkage_m"):
        return " (the base's lowest point)"
    return " (the 3D track's, at most, from the section)"


def verdict(safety: SafetyConfig, result) -> str | None:
    """The verdict in words, with each judged answer, its limit and its margin ("safe — sinkage
    0.066 m ≤ 0.1 m (margin 0.034 m); tilt 0° ≤ 2° (margin 2°)"), or None when the run was not judged."""
    metrics = result.metrics
    if "safe" not in metrics:
        return None
    parts = []
    for what, limit, metric, unit in judged(safety):
        if (margin := metrics.get(f"safety_margin_{what}")) is None:
            continue
        gap = "" if unit == "°" else " "
        value = metrics.get(metric, 0.0)
        whose = sinkage_judged(metrics) if what == "sinkage" else ""
        parts.append(f"{what} {value:.3g}{gap}{unit}{whose} {'>' if margin < 0 else '≤'} {limit:g}{gap}{unit} "
                     f"(margin {margin:.2g}{gap}{unit})")
    head = "safe" if metrics["safe"] else "unsafe"
    if result.status == "bearing_failure":
        head += ": the soil does not stop the body"
    return f"{head} — {'; '.join(parts)}" if parts else head


def sweep_tally(rows: list[dict]) -> str | None:
    """A sweep's verdicts in one phrase ("3 of 12 judged landings unsafe: sinkage 2, deceleration 1, the
    soil did not stop the body 1"), from its jobs' metrics (``safe``, ``safety_margin_*``); None when
    no job was judged."""
    def number(row, key):
        value = row.get(key)
        return None if value in (None, "") else float(value)

    judged = [row for row in rows if number(row, "safe") is not None]
    if not judged:
        return None
    unsafe = [row for row in judged if number(row, "safe") == 0.0]
    causes = [(what, sum((number(row, f"safety_margin_{what}") or 0.0) < 0.0 for row in unsafe))
              for _key, what, _metric, _unit in JUDGED]
    causes.append(("the soil did not stop the body", sum(row.get("status") == "bearing_failure" for row in unsafe)))
    by = ", ".join(f"{what} {count}" for what, count in causes if count)
    return f"{len(unsafe)} of {len(judged)} judged landings unsafe" + (f": {by}" if by else "")
