"""Soil-law parameters from site tests (``dsmv-calibrate``): the tests' data (:mod:`.data`), the fit
and its uncertainty (:mod:`.fit`), the app (:mod:`.run`). The tests' models are
:mod:`dsmv.analytic.penetrometer`'s."""
