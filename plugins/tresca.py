"""Tresca: rigid–perfectly plastic undrained strength, su = su_intact(z0) = su0 + ks·z0.

No softening and no rate effect: ``soil.sensitivity``, ``soil.xi95`` and ``soil.rate`` are
ignored, and solvers skip that arithmetic altogether.
"""

from __future__ import annotations

import numpy as np

from dsmv.soil_law import SoilLaw


class TrescaLaw(SoilLaw):
    name = "tresca"

    def strength_factor(self, xi, gamma_dot_per_s, *state):
        return np.ones(np.broadcast(np.asarray(xi), np.asarray(gamma_dot_per_s)).shape)
