"""Einav & Randolph (2005): strain softening with a rate effect.

    su = su_intact(z0) · [δrem + (1 − δrem)·exp(−3ξ/ξ95)] · R(γ̇),   δrem = 1/St

Parameters (config keys, units, typical ranges):

- ``soil.sensitivity`` St (-): intact over fully remoulded strength, 1–10 for deep-sea clays
  (Table 3 of the reference study: 1–10); St = 1 means no softening.
- ``soil.xi95`` ξ95 (-): accumulated plastic shear strain at 95 % of the strength loss, 10–50.
- ``soil.rate.law``: ``power`` (default; Herschel–Bulkley, the reference study's form)
  R = 1 + η·(γ̇/γ̇ref)^n, or ``log``: R = 1 + μ·log10(max(γ̇, γ̇ref)/γ̇ref).
- ``soil.rate.eta`` η (-): 0–0.15 (Table 3); ``soil.rate.n`` n (-), the shear-thinning index;
  ``soil.rate.gamma_dot_ref`` γ̇ref (1/s), the reference rate; ``soil.rate.mu`` μ (-), the
  strength gain per decade of strain rate for ``log``, typically 0.05–0.2.

Reference: Einav, I. & Randolph, M. F. (2005). Combining upper bound and strain path methods
for evaluating penetration resistance. Int. J. Numer. Meth. Engng 63, 1991–2016.
"""

from __future__ import annotations

import math

import numpy as np

from dsmv.soil_law import SoilLaw

POWER, LOG = 0.0, 1.0


class EinavRandolphLaw(SoilLaw):
    name = "einav_randolph"

    @property
    def softens(self) -> bool:
        return self.soil.sensitivity > 1.0

    @property
    def rate_dependent(self) -> bool:
        rate = self.soil.rate
        return rate.eta > 0.0 if rate.law == "power" else rate.mu > 0.0

    def assumptions(self) -> list[str]:
        """The power form's n and γ̇ref have no published source (docs: soil laws); the log form's
        μ and the softening parameters are Table 3's or the literature's."""
        rate = self.soil.rate
        if rate.law != "power" or not self.rate_dependent:
            return []
        return [f"soil.rate.n = {rate.n:g}", f"soil.rate.gamma_dot_ref = {rate.gamma_dot_ref:g} 1/s"]

    def parameters(self) -> np.ndarray:
        soil, rate = self.soil, self.soil.rate
        return np.array([
            1.0 / soil.sensitivity, soil.xi95, POWER if rate.law == "power" else LOG,
            rate.eta, rate.n, rate.gamma_dot_ref, rate.mu,
        ])

    @staticmethod
    def factor(xi, gamma_dot, s0, s1, d_rem, xi95, rate_law, eta, n, gamma_dot_ref, mu, unused):
        softening = d_rem + (1.0 - d_rem) * math.exp(-3.0 * xi / xi95)
        if rate_law == 0.0:
            rate = 1.0 + eta * (max(gamma_dot, 0.0) / gamma_dot_ref) ** n
        else:
            rate = 1.0 + mu * math.log10(max(gamma_dot, gamma_dot_ref) / gamma_dot_ref)
        return softening * rate

    def strength_factor(self, xi, gamma_dot_per_s, *state):
        soil, rate = self.soil, self.soil.rate
        xi = np.asarray(xi, dtype=float)
        gamma_dot = np.asarray(gamma_dot_per_s, dtype=float)
        d_rem = 1.0 / soil.sensitivity
        softening = d_rem + (1.0 - d_rem) * np.exp(-3.0 * xi / soil.xi95)
        if rate.law == "power":
            factor_rate = 1.0 + rate.eta * (np.maximum(gamma_dot, 0.0) / rate.gamma_dot_ref) ** rate.n
        else:
            factor_rate = 1.0 + rate.mu * np.log10(np.maximum(gamma_dot, rate.gamma_dot_ref) / rate.gamma_dot_ref)
        return softening * factor_rate
