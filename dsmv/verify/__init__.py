"""How we know it is right and how fast: the canonical scenes (:mod:`~dsmv.verify.canonical`), the
regression scenes (:mod:`~dsmv.verify.regression`), ``dsmv-bench`` (:mod:`~dsmv.verify.bench`,
:mod:`~dsmv.verify.bench_sweeps`) and ``dsmv-report`` (:mod:`~dsmv.verify.report`)."""
