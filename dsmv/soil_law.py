"""The soil-law plugin interface.

A soil law turns the intact strength of a piece of soil, su_intact(z0) = su0 + ks·z0
(z0: the depth where that soil started), into its current undrained strength

    su = su_intact(z0) · strength_factor(ξ, γ̇)

with ξ the accumulated plastic shear strain (-) and γ̇ the shear strain rate (1/s).
Plugins subclass :class:`SoilLaw` and register under the entry-point group
``dsmv.soil_laws``; ``soil.law`` picks one by name. The solvers never know which law
they run. Laws that neither soften nor depend on rate say so (``softens``,
``rate_dependent``) so that solvers skip that arithmetic.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from dsmv.scene import SoilConfig


class SoilLaw:
    """Base class of soil laws. Subclasses set ``name`` and override :meth:`strength_factor`."""

    name: ClassVar[str]
    #: per-cell state variables the solver advects with the material (beyond ξ and z0)
    state_names: ClassVar[tuple[str, ...]] = ()
    softens: ClassVar[bool] = False
    rate_dependent: ClassVar[bool] = False

    def __init__(self, soil: SoilConfig):
        self.soil = soil

    def strength_factor(self, xi: np.ndarray, gamma_dot_per_s: np.ndarray) -> np.ndarray:
        """su/su_intact (-) at accumulated plastic shear strain ξ and shear strain rate γ̇ (1/s).

        The plain NumPy reference ("twin") of the law; compiled kernels must agree with it.
        """
        raise NotImplementedError
