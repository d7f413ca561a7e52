"""After a run: field files (:mod:`~dsmv.post.fields`), a run's and a sweep's plots
(:mod:`~dsmv.post.plots`) and the sweep summaries of the studies (:mod:`~dsmv.post.studies`)."""
