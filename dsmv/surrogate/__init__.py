"""Surrogates of the CEL landing: the Table 3 design, the dataset from tracked runs, features,
training and evaluation, behind one plugin interface (:mod:`dsmv.surrogate.base`).

Flow: ``dsmv experiment=dataset_table3`` runs the design (:mod:`~dsmv.surrogate.design`) and
tracks every scene in MLflow; ``dsmv-train surrogate=rf|xgboost`` reads the tracked runs
(:mod:`~dsmv.surrogate.dataset`), builds features (:mod:`~dsmv.surrogate.features`), trains and
evaluates (:mod:`~dsmv.surrogate.evaluate`, :mod:`~dsmv.surrogate.train`) and registers the model.
"""
