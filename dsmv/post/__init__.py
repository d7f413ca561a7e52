"""After a run: a run's and a sweep's plots (:mod:`~dsmv.post.plots`) and the sweep summaries of the
studies (:mod:`~dsmv.post.studies`); the field files are the CEL solver's own (:mod:`dsmv.cel.fields`)."""
