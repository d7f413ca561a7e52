"""MLflow: a job's and a sweep's runs (:mod:`~dsmv.tracking.runs`), the writer process that writes them
(:mod:`~dsmv.tracking.run_writer`) and the store's check (:mod:`~dsmv.tracking.mlflow_check`)."""
