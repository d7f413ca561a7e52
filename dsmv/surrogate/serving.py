"""The registered surrogate as an MLflow model a plain client can call: scene config keys in, sinkage out.

``dsmv-train`` registers each surrogate (``models:/dsmv-sinkage-rf/latest``, ``…-xgboost/latest``)
as a Python model that wraps the fitted estimator (saved in its own flavour, an artifact) and does
the feature engineering itself. It takes a DataFrame whose columns are scene config keys::

    import mlflow, pandas as pd
    model = mlflow.pyfunc.load_model("models:/dsmv-sinkage-rf/latest")
    model.predict(pd.DataFrame({"landing.mass_kg": [4500], "geometry.width_m": [0.6], ...}))

and returns ``sinkage_m`` with the conformal interval's bounds ``sinkage_lower_m`` and
``sinkage_upper_m`` (at :data:`CONFIDENCE`), one row per scene. ``mlflow models serve -m
models:/dsmv-sinkage-rf/latest --env-manager local`` answers the same over REST. A key the
training data never varied (``landing.n_tracks``, ``landing.gravity_m_s2``, ...) may be left out: it
takes the one value the model was trained on; any other key is required (the model's signature
says which).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
from mlflow.pyfunc import PythonModel

from dsmv.surrogate.dataset import COLUMNS, PARAMETERS
from dsmv.surrogate.model import TrainedSurrogate, feature_set, load_estimator
from dsmv.surrogate.predictor import CALIBRATION_KEY, Calibration, Predictor

#: the interval a served prediction carries (-): the confidence dsmv-predict uses by default
CONFIDENCE = 0.9
OUTPUT_COLUMNS = ("sinkage_m", "sinkage_lower_m", "sinkage_upper_m")
#: the model's input artifact: the fitted estimator in its MLflow flavour
ESTIMATOR_ARTIFACT = "estimator"


def scene_frame(table: pd.DataFrame) -> pd.DataFrame:
    """A dataset table's parameter columns under their scene config keys (an input example)."""
    return table[list(PARAMETERS)].rename(columns=PARAMETERS)


def fixed_values(metadata: dict) -> dict[str, float]:
    """The parameters the training data never varied, by column, with their one value (NaN for one
    never set, such as ``inertial_mass_kg``)."""
    ranges = metadata.get("ranges", {})
    fixed = {column: lo for column, (lo, hi) in ranges.items() if lo == hi}
    return fixed | {column: math.nan for column in PARAMETERS if column not in ranges}


def dataset_table(frame: pd.DataFrame, metadata: dict) -> pd.DataFrame:
    """Scene config-key columns → the dataset table the features are built from (SI)."""
    unknown = [str(key) for key in frame.columns if key not in COLUMNS]
    if unknown:
        raise ValueError(f"unknown column(s) {', '.join(unknown)}: a dsmv sinkage model takes scene config keys, "
                         f"{', '.join(PARAMETERS.values())}")
    table = frame.rename(columns=COLUMNS).astype(float)
    fixed = fixed_values(metadata)
    missing = [PARAMETERS[c] for c in PARAMETERS if c not in table and c not in fixed]
    if missing:
        raise ValueError(f"missing column(s) {', '.join(missing)}: the model was trained on a range of each")
    for column in PARAMETERS:
        if column not in table:
            table[column] = fixed[column]
    return table[list(PARAMETERS)].reset_index(drop=True)


class SceneSinkageModel(PythonModel):
    """The registered model: the fitted estimator, its feature set and its interval calibration,
    behind scene config keys. ``model`` (a :class:`~dsmv.surrogate.model.TrainedSurrogate`) and
    ``calibration`` are what ``dsmv-predict`` unwraps."""

    def load_context(self, context) -> None:
        metadata = dict(context.model_config)
        self.model = TrainedSurrogate(load_estimator(context.artifacts[ESTIMATOR_ARTIFACT]),
                                      feature_set(metadata["feature_set"], metadata), metadata)
        record = metadata.get(CALIBRATION_KEY)
        self.calibration = Calibration.from_record(record, "model config") if record else None

    def predict(self, context, model_input: pd.DataFrame, params=None) -> pd.DataFrame:
        table = dataset_table(pd.DataFrame(model_input), self.model.metadata)
        mid, lower, upper = Predictor("", "", "", self.model, self.calibration).interval(table, CONFIDENCE)
        return pd.DataFrame(dict(zip(OUTPUT_COLUMNS, (mid, lower, upper))))


def log_scene_model(estimator_dir: Path, name: str, registered_model: str | None, metadata: dict,
                    input_example: pd.DataFrame | None, pip_requirements: list[str]):
    """Log (and register, when named) the scene model around the estimator saved at ``estimator_dir``."""
    import mlflow
    from mlflow.models import ModelSignature
    from mlflow.types import ColSpec, Schema

    config = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in metadata.items()}
    fixed = fixed_values(config)
    signature = ModelSignature(  # the keys the data never varied are optional: MLflow then passes them on absent
        inputs=Schema([ColSpec("double", key, required=column not in fixed) for column, key in PARAMETERS.items()]),
        outputs=Schema([ColSpec("double", column) for column in OUTPUT_COLUMNS]))
    return mlflow.pyfunc.log_model(name=name, python_model=SceneSinkageModel(),
                                   artifacts={ESTIMATOR_ARTIFACT: str(estimator_dir)},
                                   registered_model_name=registered_model, signature=signature,
                                   input_example=input_example, model_config=config, metadata=config,
                                   pip_requirements=pip_requirements)
