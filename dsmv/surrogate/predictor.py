"""A registered surrogate with its interval calibration: the predictor ``dsmv-predict`` and the served
model (:mod:`dsmv.surrogate.serving`) both call.

:class:`Calibration` holds the out-of-fold conformal scores of a surrogate (the record
:func:`dsmv.surrogate.intervals.calibration_record` writes, in the model metadata under
:data:`CALIBRATION_KEY` or as the run artifact ``conformal.json``); :class:`Predictor` gives z (m) and
its interval for a table of scenes; :func:`load_predictor` reads a registered model and its
calibration from an MLflow store.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from dsmv import registry
from dsmv.errors import DsmvError
from dsmv.surrogate.intervals import CALIBRATION_FILE, SCORES, BinnedScale, ScoreScale, residual_quantile
from dsmv.surrogate.model import TrainedSurrogate, load_registered
from dsmv.tracking.run_writer import open_client, resolve_uri, store_missing

CALIBRATION_KEY = "conformal"  # or the same record inside the model metadata
TARGET_SCALES = {"z_over_b": "width", "max_sinkage_m": "metre"}  # how a residual becomes metres


class PredictError(DsmvError):
    """A user mistake of dsmv-predict (store, model, calibration, CSV): one line, exit 2."""


@dataclass(frozen=True)
class Calibration:
    """Out-of-fold conformal scores of a surrogate (conformal.json): absolute residuals in its
    target's units, or scaled ones (residual / (scale_intercept + scale_slope·|ŷ|)); records
    written before ``score`` existed are absolute."""

    target: str
    residuals: np.ndarray
    method: str = "cross_conformal_pooled"
    score: str = "absolute"
    scale: ScoreScale | BinnedScale = ScoreScale()  # s(ŷ) in the target's units; (1, 0) for the absolute score

    @classmethod
    def from_record(cls, record: dict, source: str) -> "Calibration":
        try:
            target, residuals = record["target"], np.asarray(record["residuals"], dtype=float)
        except (KeyError, TypeError, ValueError):
            raise PredictError(f"{source}: a calibration needs 'target' and 'residuals' (a list of numbers)") from None
        if target not in TARGET_SCALES:
            raise PredictError(f"{source}: target {target!r} is not one of {', '.join(TARGET_SCALES)}")
        if residuals.ndim != 1 or not len(residuals) or not np.all(np.isfinite(residuals)) or np.any(residuals < 0):
            raise PredictError(f"{source}: residuals must be a non-empty list of finite numbers ≥ 0")
        score = record.get("score", cls.score)
        if score not in SCORES:
            raise PredictError(f"{source}: score {score!r} is not one of {', '.join(SCORES)}")
        try:
            if score == "binned":
                scale = BinnedScale(tuple(map(float, record["scale_edges"])), tuple(map(float, record["scale_values"])))
            else:
                scale = ScoreScale(record["scale_intercept"], record["scale_slope"]) if score == "scaled" else ScoreScale()
        except (KeyError, TypeError, ValueError) as error:
            what = ("scale_edges and scale_values (one more value than edges, values > 0)" if score == "binned"
                    else "scale_intercept and scale_slope, numbers ≥ 0, not both 0")
            raise PredictError(f"{source}: a {score} score needs {what} ({error})") from None
        return cls(target, residuals, str(record.get("method", cls.method)), score, scale)

    def half_width_m(self, table: pd.DataFrame, sinkage_m: np.ndarray, confidence: float) -> np.ndarray:
        """Half-width of the interval of z (m) per row, given the predicted z (m):
        B·q·s(z/B) for the z/B target, q·s(z) for z; s = 1 (absolute) or a + b·|ŷ| (scaled)."""
        q = residual_quantile(self.residuals, confidence)
        metres_per_unit = table["width_m"].to_numpy(float) if TARGET_SCALES[self.target] == "width" \
            else np.ones(len(table))
        prediction = np.asarray(sinkage_m, dtype=float) / metres_per_unit  # in the target's units
        return q * self.scale(prediction) * metres_per_unit


@dataclass
class Predictor:
    """A registered surrogate with its calibration: z (m) and its interval for a table of scenes."""

    name: str
    version: str
    run_id: str
    model: TrainedSurrogate
    calibration: Calibration | None

    def interval(self, table: pd.DataFrame, confidence: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(z, lower, upper) in m; lower/upper are NaN without a calibration."""
        mid = np.asarray(self.model.predict_sinkage(table), dtype=float)
        if self.calibration is None:
            nan = np.full_like(mid, np.nan)
            return mid, nan, nan
        half = self.calibration.half_width_m(table, mid, confidence)
        return mid, np.maximum(mid - half, 0.0), mid + half

    def upper(self, confidence: float):
        """``table -> upper bound of z (m)`` for :func:`dsmv.surrogate.inverse.solve_inverse`."""
        return lambda table: self.interval(table, confidence)[2]

    def describe(self) -> tuple[str, str]:
        """The model in words, for figures: what it is (``random forest (rf), dsmv-sinkage-rf v3``) and
        what it learnt from (``physics features, trained on study dataset_table3 (cel2d, einav_randolph,
        dataset 9c1e…)``), from the metadata dsmv-train recorded."""
        meta = self.model.metadata
        what = f"{surrogate_label(str(meta.get('surrogate') or '?'))}, {self.name} v{self.version}"
        recorded = [str(value) for value in (meta.get("run_settings") or {}).values() if value]
        if meta.get("dataset_hash"):
            recorded.append(f"dataset {meta['dataset_hash']}")
        learnt = f"trained on study {meta['study']}" if meta.get("study") else "training data not recorded"
        if recorded:
            learnt += f" ({', '.join(recorded)})"
        if meta.get("feature_set"):
            learnt = f"{meta['feature_set']} features, {learnt}"
        return what, learnt


def surrogate_label(name: str) -> str:
    """``random forest (rf)``: the surrogate plugin's ``label`` and its name; the name alone when the
    plugin gives no label or is not installed here."""
    try:
        label = getattr(registry.load("surrogates", name, "surrogate.name"), "label", "")
    except DsmvError:
        label = ""
    return f"{label} ({name})" if label else name


def _calibration(model: TrainedSurrogate, client, run_id: str) -> Calibration | None:
    record = model.metadata.get(CALIBRATION_KEY)
    if record is not None:
        return Calibration.from_record(record, f"model metadata '{CALIBRATION_KEY}'")
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        try:
            path = client.download_artifacts(run_id, CALIBRATION_FILE, tmp)
        except Exception:  # absent: MLflow raises its own error types per store
            return None
        return Calibration.from_record(json.loads(Path(path).read_text()), f"run {run_id} {CALIBRATION_FILE}")


def load_predictor(name: str, tracking_uri: str, version: str = "latest") -> Predictor:
    """The registered model ``name`` (``latest`` or a version number) with its calibration."""
    from mlflow.exceptions import MlflowException

    if store_missing(tracking_uri):
        raise PredictError(f"no MLflow store at {tracking_uri}: train a surrogate first (dsmv-train), "
                           "or point tracking.uri at the store that holds it")
    uri = resolve_uri(tracking_uri)
    client = open_client(uri)
    try:
        versions = client.search_model_versions(f"name='{name}'")
    except MlflowException as error:
        raise PredictError(f"cannot read registered models from {uri}: {str(error).splitlines()[0]}") from None
    if not versions:
        raise PredictError(f"no registered model '{name}' in {uri}: train one with dsmv-train")
    by_number = {str(v.version): v for v in versions}
    chosen = max(versions, key=lambda v: int(v.version)) if version == "latest" else by_number.get(str(version))
    if chosen is None:
        raise PredictError(f"model_version = {version!r}: '{name}' has versions {', '.join(sorted(by_number, key=int))}")
    model = load_registered(name, uri, str(chosen.version))
    return Predictor(name, str(chosen.version), chosen.run_id, model, _calibration(model, client, chosen.run_id))
