"""MLflow: a job's and a sweep's runs (:mod:`~dsmv.tracking.runs`), the writer process that writes them
(:mod:`~dsmv.tracking.run_writer`), the UI's server and links (:mod:`~dsmv.tracking.ui`) and the UI's
check (:mod:`~dsmv.tracking.mlflow_check`)."""
