"""The config: where the Hydra tree is and composing from it (:mod:`~dsmv.config.tree`), the schemas'
base types (:mod:`~dsmv.config.schema`), a scene's groups validated into typed objects
(:mod:`~dsmv.config.scene`) and a job's objective (:mod:`~dsmv.config.objective`)."""
