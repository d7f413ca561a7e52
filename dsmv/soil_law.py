"""The soil-law plugin interface.

A soil law turns the intact strength of a piece of soil, su_intact(z0) = su0 + ks·z0
(z0: the depth where that soil started, carried with the material), into its current
undrained strength

    su = su_intact(z0) · factor(ξ, γ̇)

with ξ the accumulated plastic shear strain (-) and γ̇ = (Δε1 − Δε3)/Δt the shear strain
rate (1/s). The solvers never know which law they run; ``soil.law`` picks one by its
entry-point name in the group ``dsmv.soil_laws``.

A law is one class with three things:

- ``parameters()``: its parameters packed as up to ``N_PARAMS`` floats (from the ``soil``
  config);
- ``factor(xi, gamma_dot, s0, s1, p0, …, p7)``: the strength factor for one material point,
  in plain Python with ``math`` (no NumPy). dsmv compiles it with Numba into a C callback of
  a fixed signature, so the CEL kernels call any law through the same cached machine code;
- ``strength_factor(xi, gamma_dot, *state)``: the same law written with NumPy arrays. It is
  the reference ("twin") that the tests hold the compiled kernel to, and what the analytic
  solver uses.

A law may also carry up to ``N_STATE`` named per-cell **state variables** (``s0``, ``s1``):
``state_variables()`` names them with their initial values, and ``evolve(k, s0, s1, xi, dxi,
gamma_dot, dt, p0, …, p7)`` returns state k's new value after a step in which the cell's
plastic shear strain grew by ``dxi`` over ``dt`` seconds. The solver stores them with the
material and advects them with it, exactly as it carries ξ and z0; soil entering the domain
brings the initial values. A law without state ignores ``s0`` and ``s1``.

A law with parameters of its own declares them as a :class:`LawParameters` model
(``parameters_model``): each field a key of ``soil.params`` with its unit in the description, its
range as bounds and a default where it has one. dsmv validates ``soil.params`` against it when a
scene is composed (a bad, unknown or missing value is a one-line error naming
``soil.params.<key>``, exit 2) and the law reads the validated values as ``self.params``.

A law that neither softens nor depends on rate for the given soil says so (``softens``,
``rate_dependent``): the solvers then skip the call and the strain-rate arithmetic, so it
costs exactly what Tresca costs.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from pydantic import BaseModel, ConfigDict

from dsmv.config.scene import SoilConfig

#: the number of float parameters a compiled law receives
N_PARAMS = 8
#: the most per-cell state variables a law may carry
N_STATE = 2


def _signature(n_leading: int):
    from numba import types

    return types.float64(*([types.float64] * (n_leading + N_PARAMS)))


_COMPILED: dict[tuple[type, str], object] = {}


class LawParameters(BaseModel):
    """Base of a law's declared parameters, the keys of ``soil.params``: a pydantic model whose fields
    carry their unit in ``description``, their range as bounds (``Field(gt=0, le=1)``) and a default
    where the law has one. Unknown keys, NaN and ±inf are refused; the values are frozen."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class SoilLaw:
    """Base class of soil laws. Subclasses set ``name`` and define ``factor`` and ``strength_factor``."""

    name: ClassVar[str]
    #: the law's own parameters (``soil.params``), declared; None: the law reads none
    parameters_model: ClassVar[type[LawParameters] | None] = None

    def __init__(self, soil: SoilConfig):
        self.soil = soil
        #: the validated ``soil.params`` (an instance of ``parameters_model``), or None
        self.params = None if self.parameters_model is None else self.parameters_model.model_validate(soil.params)

    @classmethod
    def runs_on_defaults(cls) -> bool:
        """Whether every declared parameter has a default (the law runs with ``soil.params`` empty)."""
        model = cls.parameters_model
        return model is None or not any(f.is_required() for f in model.model_fields.values())

    #: True when the strength falls with ξ for this soil
    @property
    def softens(self) -> bool:
        return False

    #: True when the strength depends on γ̇ for this soil
    @property
    def rate_dependent(self) -> bool:
        return False

    def assumptions(self) -> list[str]:
        """The parameters this soil uses whose values have no published source, each as ``key = value``:
        the run's summary lists them, so that an answer that rests on them says so."""
        return []

    def state_variables(self) -> dict[str, float]:
        """The law's per-cell state variables, by name, with their initial values (at most N_STATE)."""
        return {}

    @property
    def active(self) -> bool:
        """Whether solvers must evaluate the law at all (else factor ≡ 1 and no state)."""
        return self.softens or self.rate_dependent or bool(self.state_variables())

    def parameters(self) -> np.ndarray:
        """The law's parameters as ``N_PARAMS`` floats (unused ones zero)."""
        return np.zeros(N_PARAMS)

    @staticmethod
    def factor(xi, gamma_dot, s0, s1, p0, p1, p2, p3, p4, p5, p6, p7):
        """su/su_intact at one material point (scalar, plain Python + math); s0, s1: its state."""
        return 1.0

    @staticmethod
    def evolve(k, s0, s1, xi, dxi, gamma_dot, dt, p0, p1, p2, p3, p4, p5, p6, p7):
        """State variable k's value after a step (dxi: plastic shear strain gained, dt: s).

        Flat float64 arguments, as ``factor``'s: the C-callback signature every law shares, so the
        CEL kernels call any law through one compiled entry. Packing p0 … p7 into an array would
        hand each law a C pointer to unwrap (``numba.carray``) in place of named parameters."""
        return s0 if k == 0.0 else s1

    def strength_factor(self, xi: np.ndarray, gamma_dot_per_s: np.ndarray, *state: np.ndarray) -> np.ndarray:
        """su/su_intact (-) at accumulated plastic shear strain ξ, shear strain rate γ̇ (1/s) and
        the law's state variables (in ``state_variables()`` order): the NumPy twin."""
        raise NotImplementedError

    @classmethod
    def compiled(cls):
        """The law's ``factor`` compiled as a C callback (cached on disk by Numba)."""
        return cls._compile("factor", 4)

    @classmethod
    def compiled_evolve(cls):
        """The law's ``evolve`` compiled as a C callback (cached on disk by Numba)."""
        return cls._compile("evolve", 7)

    @classmethod
    def _compile(cls, method: str, n_leading: int):
        if (cls, method) not in _COMPILED:
            from numba import cfunc

            _COMPILED[cls, method] = cfunc(_signature(n_leading), cache=True)(getattr(cls, method))
        return _COMPILED[cls, method]

    def initial_state(self) -> np.ndarray:
        """The initial values of the state variables, checked (N_STATE at most, finite)."""
        values = np.array(list(self.state_variables().values()), dtype=float)
        if values.size > N_STATE:
            raise ValueError(f"soil law {self.name} declares {values.size} state variables; at most {N_STATE}")
        if not np.all(np.isfinite(values)):
            raise ValueError(f"soil law {self.name} starts its state at non-finite values {values}")
        return values

    def layers(self) -> list["SoilLaw"]:
        """The law in each layer of the soil (``soil.profile``'s law columns, top down); ``[self]`` when the
        table layers none. Every layer's law starts its state variables at the same values."""
        soils = self.soil.layer_soils()
        if len(soils) == 1:
            return [self]
        laws = [type(self)(soil) for soil in soils]
        first = laws[0].initial_state()
        if any(not np.array_equal(law.initial_state(), first) for law in laws[1:]):
            raise ValueError(f"soil law {self.name} starts its state at values that differ between the table's layers")
        return laws

    @property
    def layer_tops(self) -> np.ndarray:
        """The top depth of each of :meth:`layers` (m; the first −∞)."""
        layers = self.soil.law_layers
        return np.array([-np.inf]) if layers is None else layers.top

    @property
    def any_layer_active(self) -> bool:
        """Whether solvers must evaluate the law in some layer (:attr:`active` in any of :meth:`layers`)."""
        return any(law.active for law in self.layers())

    def packed(self) -> np.ndarray:
        """``parameters()`` checked and padded to ``N_PARAMS`` floats."""
        params = np.zeros(N_PARAMS)
        given = np.asarray(self.parameters(), dtype=float)
        if given.size > N_PARAMS:
            raise ValueError(f"soil law {self.name} packs {given.size} parameters; at most {N_PARAMS}")
        params[: given.size] = given
        if not np.all(np.isfinite(params)):
            raise ValueError(f"soil law {self.name} packed non-finite parameters {params}")
        return params

