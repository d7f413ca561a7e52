"""A trained surrogate as a predictor: a scene (or a table of scenes) in, sinkage out.

``dsmv-train`` saves each model in its MLflow flavour with metadata (feature set, target, the
study's implicit-solve range, the training ranges of every parameter, the dataset hash). This
module reads it back for prediction (``dsmv-predict``):

    model = load_registered("dsmv-sinkage-rf", tracking_uri="sqlite:///runs/mlflow.db")
    z_m = model.predict_sinkage(scene_table([scene]))
    outside = model.out_of_range(table)       # {column: [row indices]} beyond the training data
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from dsmv.errors import ConfigError
from dsmv.surrogate.dataset import PARAMETERS
from dsmv.surrogate.fast_model import PhysicsFeatures
from dsmv.surrogate.features import FeatureSet, LeakFreeFeatures, StudyFeatures
from dsmv.tracking.run_writer import resolve_uri


#: the feature sets by name (``train.features``, and what a trained model records)
FEATURE_SETS: dict[str, type[FeatureSet]] = {"physics": PhysicsFeatures, "leak_free": LeakFreeFeatures,
                                              "study": StudyFeatures}


def feature_set(name: str, metadata: dict | None = None) -> FeatureSet:
    """The feature set called ``name`` (``train.features``); ``metadata``: a trained model's, whose
    recorded settings rebuild the features it was trained on."""
    if name not in FEATURE_SETS:
        raise ConfigError("train.features", name, f"must be one of {', '.join(FEATURE_SETS)}")
    if name == "physics":
        return PhysicsFeatures((metadata or {}).get("fast_model"))
    return FEATURE_SETS[name]()


def scene_table(scenes) -> pd.DataFrame:
    """Validated :class:`~dsmv.config.scene.Scene` objects → a dataset-style table (one row each, SI)."""
    rows = []
    for scene in scenes:
        landing, body, soil = scene.landing, scene.geometry, scene.soil
        rows.append({
            "mass_kg": landing.mass_kg,
            "inertial_mass_kg": np.nan if landing.inertial_mass_kg is None else landing.inertial_mass_kg,
            "velocity_m_s": landing.velocity_m_s, "n_tracks": float(landing.n_tracks),
            "gravity_m_s2": landing.gravity_m_s2, "width_m": body.width_m,
            "contact_length_m": body.contact_length_m, "su0_pa": soil.su0_pa, "ks_pa_per_m": soil.ks_pa_per_m,
            "sensitivity": soil.sensitivity, "xi95": soil.xi95, "eta": soil.rate.eta,
        })
    return pd.DataFrame(rows, columns=list(PARAMETERS))


@dataclass
class TrainedSurrogate:
    """A fitted estimator with what it needs to predict sinkage: its feature set and metadata."""

    estimator: Any
    features: FeatureSet
    metadata: dict

    def predict_sinkage(self, table: pd.DataFrame) -> np.ndarray:
        """Sinkage z (m) of each row; the study's features solve their implicit equation."""
        return self.features.predict_sinkage(self.estimator, table, z_max_m=self.metadata.get("implicit_z_max_m", 2.0))

    def out_of_range(self, table: pd.DataFrame) -> dict[str, list[int]]:
        """Rows whose parameters lie outside the training data's range, by column."""
        outside = {}
        for column, (lo, hi) in self.metadata.get("ranges", {}).items():
            values = table[column].to_numpy(float)
            rows = np.flatnonzero((values < lo) | (values > hi))
            if len(rows):
                outside[column] = rows.tolist()
        return outside


def load_estimator(path: str):
    """A fitted estimator saved in its MLflow flavour (xgboost, else scikit-learn) at ``path`` (a
    local folder or a model URI)."""
    import mlflow
    from mlflow.models import get_model_info

    if "xgboost" in get_model_info(str(path)).flavors:
        return mlflow.xgboost.load_model(str(path))
    return mlflow.sklearn.load_model(str(path))  # the trusted types saved with it travel in its MLmodel file


def load_registered(name: str, tracking_uri: str, version: str = "latest") -> TrainedSurrogate:
    """Load ``models:/<name>/<version>`` with its dsmv metadata (an MLflow client call, then the model)."""
    import mlflow
    from mlflow.models import get_model_info

    mlflow.set_tracking_uri(resolve_uri(tracking_uri))
    uri = f"models:/{name}/{version}"
    info = get_model_info(uri)
    if "python_function" in info.flavors and info.flavors["python_function"].get("python_model"):
        return mlflow.pyfunc.load_model(uri).unwrap_python_model().model  # the scene model (dsmv.surrogate.serving)
    metadata = dict(info.metadata)
    return TrainedSurrogate(load_estimator(uri), feature_set(metadata["feature_set"], metadata), metadata)
