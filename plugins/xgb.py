"""Surrogate ``xgboost``: gradient-boosted trees (XGBoost's scikit-learn API), the comparator.

The module is not called ``xgboost.py``: that would shadow the library."""

from __future__ import annotations

from dsmv.surrogate.base import Surrogate


class XGBoostSurrogate(Surrogate):
    name = "xgboost"
    label = "gradient-boosted trees"
    flavor = "mlflow.xgboost"
    requirements = (("xgboost-cpu", "xgboost"), ("scikit-learn",))

    def make(self, **params):
        from xgboost import XGBRegressor

        return XGBRegressor(random_state=self.seed, n_jobs=self.n_jobs, tree_method="hist", **params)
