"""Surrogate ``rf``: scikit-learn's random forest, the reference study's model (its Table 4
gives n_estimators 146, max_depth 9, min_samples_split 2, min_samples_leaf 1, max_features 4)."""

from __future__ import annotations

from dsmv.surrogate.base import Surrogate


class RandomForestSurrogate(Surrogate):
    name = "rf"
    label = "random forest"
    flavor = "mlflow.sklearn"
    # MLflow 3 saves scikit-learn models with skops, which refuses types it cannot vouch for.
    # The trees are ours (fitted in this process), so their node storage is trusted.
    log_model_kwargs = {"skops_trusted_types": ["sklearn.tree._tree.Tree"]}

    def make(self, **params):
        from sklearn.ensemble import RandomForestRegressor

        return RandomForestRegressor(random_state=self.seed, n_jobs=self.n_jobs, **params)
