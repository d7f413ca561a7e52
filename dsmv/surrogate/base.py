"""The surrogate plugin interface (entry-point group ``dsmv.surrogates``).

A surrogate plugin is a small class that makes an unfitted scikit-learn-compatible regressor
from hyper-parameters and saves a fitted one in MLflow's model format. Everything else
(features, grid search, evaluation, tracking) is shared and lives in :mod:`dsmv.surrogate`.

Write your own::

    class MySurrogate(Surrogate):
        name = "my_model"
        label = "my regressor"  # in words, for figures
        registered_model = "dsmv-sinkage-my_model"

        def make(self, **params):
            return MyRegressor(random_state=self.seed, **params)

and register it under ``[project.entry-points."dsmv.surrogates"]`` with a config
``conf/surrogate/my_model.yaml`` (``name``, ``params``, ``grid``).
"""

from __future__ import annotations

from typing import Any, ClassVar

from pydantic import Field

from dsmv.config.schema import Count, Schema


class SurrogateConfig(Schema):
    """Config of a ``surrogate`` option (``conf/surrogate/<name>.yaml``)."""

    name: str = Field(description="surrogate plugin (entry point in dsmv.surrogates)")
    registered_model: str = Field(description="MLflow registered model name")
    params: dict[str, Any] = Field(default_factory=dict, description="fixed hyper-parameters")
    grid: dict[str, list[Any]] = Field(default_factory=dict, description="grid-searched hyper-parameters")
    grid_cv_folds: Count = Field(5, ge=2, description="folds of the grid search's cross-validation (-)")


class Surrogate:
    """Base class of surrogate plugins."""

    name: ClassVar[str] = ""
    #: what the model is, in words ("random forest"): figures name it beside ``name``
    label: ClassVar[str] = ""
    #: MLflow flavour module used by :meth:`log_model` (``mlflow.sklearn``, ``mlflow.xgboost``)
    flavor: ClassVar[str] = "mlflow.sklearn"
    #: extra keyword arguments of the flavour's ``log_model``
    log_model_kwargs: ClassVar[dict[str, Any]] = {}
    #: distributions the saved model needs, each as alternatives ("xgboost-cpu", "xgboost"): pinned to
    #: the installed version, which spares MLflow its requirement inference (a subprocess, 10–20 s)
    requirements: ClassVar[tuple[tuple[str, ...], ...]] = (("scikit-learn",),)

    def __init__(self, seed: int = 0, n_jobs: int = 1):
        self.seed = seed  # random_state of the estimator (-)
        self.n_jobs = n_jobs  # threads of one fit (-); the trainer parallelises across fits instead

    def make(self, **params):
        """An unfitted regressor with ``params`` (fit(X, y), predict(X), feature_importances_)."""
        raise NotImplementedError

    def check_params(self, params: dict[str, Any]) -> str | None:
        """Why ``make(**params)`` gives no regressor to fit, in one line, or None; no fit. By default the
        regressor's constructor (an unknown name) and, for a scikit-learn regressor, its declared
        parameter constraints (a negative count, a wrong type); a plugin may check more."""
        try:
            estimator = self.make(**params)
        except (TypeError, ValueError) as error:
            return _first_line(error)
        if getattr(estimator, "_parameter_constraints", None) is None:  # not a scikit-learn estimator's
            return None
        try:
            estimator._validate_params()  # scikit-learn >= 1.2: what fit would check first
        except (TypeError, ValueError) as error:
            return _first_line(error)
        except Exception:  # another scikit-learn's private API: its fit will check
            return None
        return None

    def save_model(self, estimator, path) -> None:
        """Save ``estimator`` in its MLflow flavour to the folder ``path``."""
        import importlib

        flavor = importlib.import_module(self.flavor)
        model_arg = "xgb_model" if self.flavor == "mlflow.xgboost" else "sk_model"
        flavor.save_model(**{model_arg: estimator}, path=str(path), pip_requirements=pinned_requirements(self.requirements),
                          **self.log_model_kwargs)

    def log_model(self, estimator, name: str, registered_model: str | None, input_example, metadata: dict):
        """Log ``estimator`` in the active MLflow run inside the scene model of
        :mod:`dsmv.surrogate.serving` (config keys in, sinkage out; the estimator in its flavour
        within); register it when named. ``input_example``: scene config-key columns, or None."""
        import tempfile
        from pathlib import Path

        from dsmv.surrogate.serving import log_scene_model

        with tempfile.TemporaryDirectory() as scratch:
            folder = Path(scratch) / "estimator"
            self.save_model(estimator, folder)
            return log_scene_model(folder, name, registered_model, metadata, input_example,
                                   pinned_requirements((("mlflow",), *self.requirements)))


def _first_line(error: Exception) -> str:
    return next((line.strip() for line in str(error).splitlines() if line.strip()), type(error).__name__)


def pinned_requirements(requirements: tuple[tuple[str, ...], ...]) -> list[str]:
    """``name==version`` of the first installed distribution of each group of alternatives."""
    from importlib.metadata import PackageNotFoundError, version

    pins = []
    for alternatives in requirements:
        for dist in alternatives:
            try:
                pins.append(f"{dist}=={version(dist)}")
                break
            except PackageNotFoundError:
                continue
    return pins
