"""The result contract of one job: ``result.json`` and the time-history CSV.

``result.json``: ``{"status", "message", "solver", "soil_law", "metrics": {name: number},
"units": {name: unit}, "dsmv_version", "config_hash"}``. Metric names carry their unit
where it is ambiguous (``max_sinkage_m``). Sweep-level summaries use other file names.
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import dsmv

#: ok: the body came to rest (or the push finished); bearing_failure: the soil cannot stop
#: the body; out_of_domain: the body neared the mesh edge; unstable: a numerical guard
#: tripped; failed: the code raised; interrupted: SIGINT or SIGTERM stopped the run (it never
#: feeds surrogates).
STATUSES = ("ok", "bearing_failure", "out_of_domain", "unstable", "failed", "interrupted")

#: the process's exit code for each status (a sweep exits with its worst job's, see EXIT_SEVERITY).
#: bearing_failure is an answer (the soil cannot stop the body), not a crash: 0, like ok. 2 is a
#: configuration error, before any run (dsmv.app.runner.fail_user_error).
EXIT_CODES = {"ok": 0, "bearing_failure": 0, "failed": 1, "unstable": 3, "out_of_domain": 4, "interrupted": 130}
#: statuses from the most severe down, for a sweep's exit code
EXIT_SEVERITY = ("failed", "interrupted", "unstable", "out_of_domain", "bearing_failure", "ok")

RESULT_FILE = "result.json"
HISTORY_FILE = "history.csv"
#: columns of the time history, with units in their names
HISTORY_COLUMNS = ("time_s", "sinkage_m", "velocity_m_s", "force_n")
#: columns a history holds when its run has them: a track's plates' sinkage (:func:`add_plate_sinkage`)
OPTIONAL_HISTORY_COLUMNS = ("plate_sinkage_m",)


@dataclass
class SolveResult:
    """What a solver returns. ``history`` maps HISTORY_COLUMNS to equal-length arrays."""

    status: str
    message: str
    metrics: dict[str, float] = field(default_factory=dict)
    units: dict[str, str] = field(default_factory=dict)
    history: dict[str, np.ndarray] | None = None

    def __post_init__(self):
        if self.status not in STATUSES:
            raise ValueError(f"status {self.status!r} is not one of {STATUSES}")
        for name, value in self.metrics.items():
            # A NaN never leaves silently: a solver must report 'unstable' instead.
            if not math.isfinite(value):
                raise ValueError(f"metric {name} = {value} is not finite")
        for name, values in (self.history or {}).items():
            if not np.all(np.isfinite(np.asarray(values, dtype=float))):
                raise ValueError(f"history column {name} holds a non-finite value")


def write_result(run_dir: Path, result: SolveResult, solver: str, soil_law: str, config_hash: str) -> Path:
    """Write ``result.json`` into ``run_dir`` and return its path."""
    payload = {
        "status": result.status,
        "message": result.message,
        "solver": solver,
        "soil_law": soil_law,
        "metrics": {k: float(v) for k, v in result.metrics.items()},
        "units": dict(result.units),
        "dsmv_version": dsmv.__version__,
        "config_hash": config_hash,
    }
    path = Path(run_dir) / RESULT_FILE
    path.write_text(json.dumps(payload, indent=2) + "\n")
    return path


def history_columns(history: dict[str, np.ndarray]) -> tuple[str, ...]:
    """The columns a history has: :data:`HISTORY_COLUMNS`, then those of :data:`OPTIONAL_HISTORY_COLUMNS`
    it holds, then any other it holds in its order (a body that slides or turns: its loads, rotation and
    displacement, :data:`dsmv.cel.controller.MOTION_COLUMNS`)."""
    optional = tuple(c for c in OPTIONAL_HISTORY_COLUMNS if c in history)
    return HISTORY_COLUMNS + optional + tuple(c for c in history if c not in HISTORY_COLUMNS + optional)


def add_plate_sinkage(result: SolveResult, grouser_height_m: float) -> None:
    """A track's second sinkage, ``plate_sinkage_m``: its plates' underside, the grouser height above
    the body's reference (``max_sinkage_m``, the grousers' tips where the model has grousers; a model
    without them, such as the 2D cross-section, bears on the plates: the two are equal). Negative: the
    plates stayed that far above the mudline. Added to the metrics and the history."""
    if "max_sinkage_m" in result.metrics:
        result.metrics["plate_sinkage_m"] = result.metrics["max_sinkage_m"] - grouser_height_m
        result.units["plate_sinkage_m"] = "m"
    if result.history is not None and "sinkage_m" in result.history:
        result.history["plate_sinkage_m"] = np.asarray(result.history["sinkage_m"], dtype=float) - grouser_height_m


def add_vehicle_answers(metrics: dict, units: dict, history: dict, body, plates_m: float) -> None:
    """A vehicle's tilt and tracks, from the history of the middle of its base (``sinkage_m``), its roll
    (``rotation_deg``, about y) and, where the model pitches, its pitch (``pitch_deg``, about x): its
    largest roll and pitch either way (``max_roll_deg``, ``max_pitch_deg``, the history's samples), its tilt
    from level at the end (``final_tilt_deg``); each
    track's middle (``max_sinkage_left_track_m``, ``final_…``), its front (+y) and rear ends where it
    pitches (``…_track_front_m``, ``…_track_rear_m``), the grousers' tips; and its plates' deepest
    (``max_plate_sinkage_left_track_m``), ``plates_m`` above the tips. A point of the base x across and y
    along from its middle sits lower than the middle by sin θy·x − cos θy·sin θx·y (the last row of the
    body's turn, :meth:`dsmv.cel.body.Pose.turned`)."""
    middle = np.asarray(history["sinkage_m"])
    roll = np.radians(np.asarray(history["rotation_deg"]))
    pitch = np.radians(np.asarray(history["pitch_deg"])) if "pitch_deg" in history else None
    for name, angle in (("max_roll_deg", roll), ("max_pitch_deg", pitch)):
        if angle is not None:
            metrics[name], units[name] = float(np.degrees(np.abs(angle).max())), "deg"
    # the base's normal turned by the roll and the pitch stands cos θy·cos θx from vertical
    upright = np.cos(roll[-1]) * (1.0 if pitch is None else np.cos(pitch[-1]))
    metrics["final_tilt_deg"], units["final_tilt_deg"] = float(np.degrees(np.arccos(min(upright, 1.0)))), "deg"
    ends = {"": 0.0} if pitch is None else {"": 0.0, "_front": 0.5 * body.contact_length_m,
                                            "_rear": -0.5 * body.contact_length_m}
    for side, sign in (("left", -1.0), ("right", 1.0)):
        deepest = -np.inf
        for end, along in ends.items():
            track = middle + np.sin(roll) * sign * body.track_offset_m
            if along:
                track = track - np.cos(roll) * np.sin(pitch) * along
            name = f"{side}_track{end}"
            metrics |= {f"max_sinkage_{name}_m": float(track.max()), f"final_sinkage_{name}_m": float(track[-1])}
            units |= {f"max_sinkage_{name}_m": "m", f"final_sinkage_{name}_m": "m"}
            deepest = max(deepest, float(track.max()))
        metrics[f"max_plate_sinkage_{side}_track_m"] = deepest - plates_m
        units[f"max_plate_sinkage_{side}_track_m"] = "m"


def write_history(run_dir: Path, history: dict[str, np.ndarray]) -> Path:
    """Write the time history as CSV with a header of its columns (:func:`history_columns`)."""
    path = Path(run_dir) / HISTORY_FILE
    names = history_columns(history)
    columns = [np.asarray(history[c], dtype=float) for c in names]
    with path.open("w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(names)
        writer.writerows(zip(*(c.tolist() for c in columns)))
    return path

