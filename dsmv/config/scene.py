"""Config → validated, typed scene objects.

Every config group has a schema here. :func:`build_scene` validates a composed Hydra
config group by group and raises :class:`~dsmv.errors.ConfigError` naming the config
path, the value and what is allowed, for the first wrong value it meets. Plugins
(``soil.law``, ``solver.name``) are checked against what is installed.

Units: SI throughout; names carry them (``mass_kg``, ``su0_pa``).
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal, Optional, Union

import numpy as np
from omegaconf import DictConfig, OmegaConf, open_dict
from omegaconf.errors import OmegaConfBaseException
from pydantic import BaseModel, BeforeValidator, Field, ValidationInfo, field_validator, model_validator

from dsmv import registry
from dsmv.config.location import CONFIG_DIR
from dsmv.config.objective import objective_config
from dsmv.config.profile import (DENSITY_KEY, KEY as PROFILE_KEY, DensityLayers, LawLayers, StrengthSegments,
                                 law_layers, read_points, segments, straight_line, weighed)
from dsmv.config.schema import Count, Number, Schema, _validate
from dsmv.errors import ConfigError

# --------------------------------------------------------------------------- resolvers


def _multiply(a, b) -> float:
    for value in (a, b):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ValueError(f"{value!r} is not a number")
    return float(a) * float(b)


def register_resolvers() -> None:
    """OmegaConf resolvers used by conf/ (``${dsmv.mul:500,${soil.su0_pa}}`` → E = 500·su0)."""
    OmegaConf.register_new_resolver("dsmv.mul", _multiply, replace=True)


def _to_container(cfg: DictConfig) -> dict:
    """Resolve a config (not its ``hydra`` node); a failing interpolation is a ConfigError on its key."""
    try:
        return {key: _resolve(cfg[key]) for key in cfg if key != "hydra"}
    except OmegaConfBaseException as exc:
        key = getattr(exc, "full_key", None) or "<config>"
        raw: Any = OmegaConf.to_container(cfg, resolve=False)
        for part in key.split("."):
            raw = raw.get(part) if isinstance(raw, dict) else None
        reason = str(exc).splitlines()[0].split("while resolving interpolation: ")[-1]
        raise ConfigError(key, raw, f"cannot be resolved: {reason}") from None


def _resolve(node: Any) -> Any:
    return OmegaConf.to_container(node, resolve=True) if isinstance(node, DictConfig) else node


register_resolvers()

# --------------------------------------------------------------------------- soil


class RateConfig(Schema):
    """Strain-rate dependence R(γ̇) of the undrained strength (Einav & Randolph 2005 form).

    ``power``: R = 1 + η·(γ̇/γ̇ref)^n (Herschel–Bulkley, the reference study's form).
    ``log``:   R = 1 + μ·log10(max(γ̇, γ̇ref)/γ̇ref).
    """

    law: Literal["power", "log"] = "power"
    eta: Number = Field(0.0, ge=0, description="power-law viscosity coefficient η (-), 0-0.15 in Table 3")
    n: Number = Field(gt=0, le=1, description="shear-thinning index n (-)")
    gamma_dot_ref: Number = Field(gt=0, description="reference shear strain rate γ̇ref (1/s)")
    mu: Number = Field(0.0, ge=0, description="log-law rate parameter μ per decade (-)")


class SoilConfig(Schema):
    """A soil profile: su_intact(z) = su0 + ks·z, or a table of su against depth (``profile``,
    :mod:`dsmv.config.profile`), softening, rate, elasticity, buoyant density."""

    name: str
    law: str = Field(description="soil-law plugin (entry point in dsmv.soil_laws)")
    su0_pa: Number = Field(gt=0, description="intact undrained shear strength at the mudline (Pa)")
    ks_pa_per_m: Number = Field(ge=0, description="strength gradient with depth (Pa/m)")
    sensitivity: Number = Field(ge=1, description="sensitivity St = su_intact/su_remoulded (-)")
    xi95: Number = Field(gt=0, description="accumulated plastic shear strain for 95 % softening (-)")
    rate: RateConfig
    density_kg_m3: Number = Field(gt=0, description="submerged (buoyant) density ρ' (kg/m³)")
    youngs_modulus_pa: Number = Field(gt=0, description="Young's modulus E (Pa)")
    poisson_ratio: Number = Field(ge=0, lt=0.5, description="Poisson's ratio ν (-), < 0.5")
    params: dict[str, Number] = Field(default_factory=dict, description="law-specific parameters (see the law)")
    profile: Optional[Union[list[list[Number]], dict[str, list[Number]], str]] = Field(None, description=(
        "su_intact against depth: [[depth_m, su_pa], ...], columns {depth_m: [...], su_pa: [...], ...} or a CSV "
        "path (columns depth_m|depth_cm, su_pa|su_kpa); further columns layer the law's values by soil key "
        "(sensitivity, xi95, rate.eta, ..., params.<name>) and the density (density_kg_m3); null: su0 + ks·z"))
    profile_scale: Number = Field(1.0, gt=0, description=(
        "factor on the table's strengths (-): the profile's shape from the site, its level fitted "
        "(dsmv-calibrate); a straight line's level is su0_pa and ks_pa_per_m; youngs_modulus_pa is not scaled"))
    slope_deg: Number = Field(0.0, ge=0, lt=90, description=(
        "seabed slope β (°): the level grid with gravity turned by β, the soil at rest as an infinite slope, "
        "depths and strengths normal to the seabed"))
    downslope_direction_deg: Number = Field(0.0, description=(
        "where the seabed falls, in plan from +x (across the body) towards +y (along it) (°); plane strain: 0 or 180"))

    @model_validator(mode="after")
    def _profile_sets_the_mudline(self):
        """A table is the strength: su0 and ks become its mudline strength and first gradient, so that every
        reader of them (scales, normalisations) sees the table's."""
        if self.profile is None and self.profile_scale != 1.0:
            raise ConfigError("soil.profile_scale", self.profile_scale, "scales a table (soil.profile); a straight "
                              "line's strength is soil.su0_pa and soil.ks_pa_per_m")
        if self.profile is not None:
            table = self.strength
            object.__setattr__(self, "su0_pa", float(table.su(0.0)))
            object.__setattr__(self, "ks_pa_per_m", float(table.slope[0]))
            # each layer's values checked as the soil's are, one line naming the column
            self.layer_soils(law_layers(self.profile, "all"))
            if (density := law_layers(self.profile, "density")) is not None:  # the mudline's, as su0 is the table's
                object.__setattr__(self, "density_kg_m3", float(density.values[DENSITY_KEY][density.at(0.0)]))
        return self

    @property
    def law_layers(self) -> "LawLayers | None":
        """The law's values by layer when the table layers them (:func:`dsmv.config.profile.law_layers`)."""
        return None if self.profile is None else law_layers(self.profile)

    @property
    def density_layers(self) -> "DensityLayers | None":
        """The buoyant density by layer when the table layers it (a ``density_kg_m3`` column)."""
        layers = None if self.profile is None else law_layers(self.profile, "density")
        return None if layers is None else DensityLayers.of(layers)

    @property
    def lightest_density_kg_m3(self) -> float:
        """The lightest buoyant density at any depth (kg/m³): the fastest elastic waves."""
        layers = self.density_layers
        return self.density_kg_m3 if layers is None else layers.lightest_kg_m3

    def layer_soils(self, layers: "LawLayers | None" = None) -> "list[SoilConfig]":
        """The soil of each of the law's layers (or of ``layers``): this soil with that layer's values (one
        layer: itself)."""
        layers = self.law_layers if layers is None else layers
        if layers is None:
            return [self]
        out = []
        for k in range(len(layers.top)):
            tree = self.model_dump()
            tree["profile"] = None
            tree["profile_scale"] = 1.0
            for key, values in layers.values.items():
                node = tree
                *parents, leaf = key.split(".")
                for part in parents:
                    node = node[part]
                node[leaf] = float(values[k])
            try:
                out.append(_validate(SoilConfig, tree, "soil"))
            except ConfigError as error:
                where = "the first layer" if k == 0 else f"the layer from {layers.top[k]:g} m"
                column = error.path.removeprefix("soil.")
                raise ConfigError(PROFILE_KEY, f"{where}'s {column} {error.value!r}", error.allowed) from None
        return out

    @property
    def strength(self) -> "StrengthSegments":
        """su_intact(z) as segments (:class:`dsmv.config.profile.StrengthSegments`)."""
        if self.profile is None:
            return straight_line(self.su0_pa, self.ks_pa_per_m)
        points = read_points(self.profile)
        if self.profile_scale != 1.0:
            points = points * np.array([1.0, self.profile_scale])
        return segments(points)

    @property
    def bent_strength(self) -> "StrengthSegments | None":
        """The strength table when it is not one straight line; None when su_intact is su0 + ks·z (what the
        analytic models read from su0_pa and ks_pa_per_m)."""
        if self.profile is None:
            return None
        strength = self.strength
        return None if strength.straight else strength

    def gravity_components(self, gravity_m_s2: float) -> tuple[float, float, float]:
        """Gravity in the grid's frame, which lies along the seabed (m/s²): along +x and +y (downslope
        positive) and its magnitude down the normal, g·sinβ·cos α, g·sinβ·sin α, g·cos β."""
        beta, alpha = math.radians(self.slope_deg), math.radians(self.downslope_direction_deg)
        if beta == 0.0:
            return 0.0, 0.0, gravity_m_s2
        along = gravity_m_s2 * math.sin(beta)
        return along * _exact_cos(alpha), along * _exact_cos(alpha - 0.5 * math.pi), gravity_m_s2 * math.cos(beta)

    def level_across(self, axis: str) -> bool:
        """Whether the seabed falls nowhere along ``axis`` (x or y): a mid-plane normal to it stays a
        symmetry plane."""
        return self.gravity_components(1.0)["xy".index(axis)] == 0.0

    def steepest_slope_deg(self, gravity_m_s2: float, depth_m: float) -> float:
        """The steepest seabed this soil stands as an infinite slope down to ``depth_m`` (°): at every depth
        d (normal to the seabed) the Tresca radius of its state at rest, ρ'·g·d·√((1 − K0)²·cos²β/4 + sin²β)
        (the at-rest normal stresses' difference, K0 = ν/(1 − ν) as the CEL sets them, and the slope's
        shear), stays below the intact strength su(d). su(d)/d is least at the ends of the table's
        segments. On level ground the check is not made."""
        if gravity_m_s2 <= 0.0:
            return 90.0
        table, density = self.strength, self.density_layers
        # a layered density weighs d as its weighing depth w(d): su(d)/w(d) is least where either bends
        bends = [*table.depth[1:], *(density.top[1:] if density is not None else [])]
        depths = np.array(sorted({d for d in bends if 0.0 < d < depth_m} | {depth_m}))
        rho, weighed_depths = weighed(self.density_kg_m3, density, depths)
        ratio = float(np.min(table.su(depths) / weighed_depths)) / (rho * gravity_m_s2)
        half_difference = 0.5 * (1.0 - self.poisson_ratio / (1.0 - self.poisson_ratio))
        if ratio <= half_difference:
            return 0.0
        return math.degrees(math.asin(min(math.sqrt((ratio**2 - half_difference**2) / (1.0 - half_difference**2)), 1.0)))


def _exact_cos(angle: float) -> float:
    """cos, exactly 0 or ±1 at multiples of a right angle (a slope along x has no y component at all)."""
    quarter = angle / (0.5 * math.pi)
    if abs(quarter - round(quarter)) < 1e-12:
        return (1.0, 0.0, -1.0, 0.0)[round(quarter) % 4]
    return math.cos(angle)


# --------------------------------------------------------------------------- geometry


def _check_roughness(value):
    if isinstance(value, str) and value in ("rough", "smooth"):
        return value
    if isinstance(value, (int, float)) and not isinstance(value, bool) and 0.0 <= value <= 1.0:
        return float(value)
    raise ValueError("must be 'rough', 'smooth' or an adhesion factor α in [0, 1]")


Roughness = Annotated[Union[str, float], BeforeValidator(_check_roughness)]


class BodyConfig(Schema):
    """A rigid body: width B (m) across the section, contact length L (m), interface roughness."""

    name: str
    kind: str
    width_m: Number = Field(gt=0, description="width B (m)")
    contact_length_m: Number = Field(gt=0, description="contact length L (m); contact area A = B·L")
    roughness: Roughness = "rough"

    @property
    def contact_area_m2(self) -> float:
        """Contact area A = B·L (m²) of one track."""
        return self.width_m * self.contact_length_m

    @property
    def adhesion_factor(self) -> float:
        """Interface shear limit as a fraction α of su: rough 1, smooth 0."""
        return {"rough": 1.0, "smooth": 0.0}.get(self.roughness, self.roughness)

    @property
    def vehicle(self) -> bool:
        """Two tracks side by side (a track with ``gauge_m``)."""
        return getattr(self, "gauge_m", None) is not None

    @property
    def track_offset_m(self) -> float:
        """How far each track's centre stands off the body's middle across x (m): half a vehicle's gauge, else 0."""
        return 0.5 * self.gauge_m if self.vehicle else 0.0

    @property
    def half_span_m(self) -> float:
        """Half the body's width across x (m): B/2, or a vehicle's from its middle to its tracks' outer walls."""
        return 0.5 * self.width_m + self.track_offset_m

    def box_inertia_kg_m2(self, mass_kg: float) -> tuple[float, float, float]:
        """A uniform box of ``mass_kg`` as wide as the body's span, L long and as high as a track's sprockets
        (else B): its inertia about x, y and z through its centre, m·(L² + h²)/12, m·(B² + h²)/12,
        m·(B² + L²)/12 (kg·m²)."""
        B, L = 2.0 * self.half_span_m, self.contact_length_m or self.width_m
        height = 2.0 * self.sprocket_radius_m if self.kind == "track" else B
        return (mass_kg * (L**2 + height**2) / 12.0, mass_kg * (B**2 + height**2) / 12.0,
                mass_kg * (B**2 + L**2) / 12.0)


class TrackGeometry(BodyConfig):
    """The Pioneering-I track (section 2.3 of the reference study)."""

    kind: Literal["track"]
    view: Literal["cross_section", "longitudinal"] = "cross_section"
    sprocket_radius_m: Number = Field(gt=0)
    sprocket_spacing_m: Number = Field(gt=0, description="distance between sprocket centres (m)")
    plate_pitch_m: Number = Field(gt=0)
    plate_thickness_m: Number = Field(gt=0)
    grouser_height_m: Number = Field(ge=0)
    grousers: Literal["trapped_soil", "cells"] = Field("trapped_soil", description=(
        "how the side view (longitudinal, 3D) models the grousers: trapped_soil, the soil between them "
        "moves with the track (a flat base at their tips, the same on every mesh) | cells, a column of "
        "core cells at every pitch, at least one cell high"))
    section_base: Literal["plates", "grouser_tips"] = Field("plates", description=(
        "the cross-section's base (cel2d, view=cross_section): plates, the study's section, the grousers left "
        "out | grouser_tips, the section of the track cel3d lands: the grousers' envelope, its base at their "
        "tips, landing once they have cut in, the soil they trap moving with it and holding the soil beside "
        "it (the side view and cel3d always model it so)"))
    gauge_m: Optional[Number] = Field(None, gt=0, description=(
        "a vehicle: the distance between its two tracks' centres (m), the weight shared by them "
        "(landing.n_tracks = 2); cel3d lands both as one rigid body; null: one track alone"))

    @field_validator("section_base")
    @classmethod
    def _section_of_the_trapped_soil(cls, base, info: ValidationInfo):
        if base == "grouser_tips" and info.data.get("view") == "longitudinal":
            raise ValueError("the side view models the grousers itself: the section's base is the cross-section's")
        if base == "grouser_tips" and info.data.get("grousers") != "trapped_soil":
            raise ValueError("a base at the grousers' tips is their trapped soil's envelope: geometry.grousers=trapped_soil")
        return base

    @field_validator("gauge_m")
    @classmethod
    def _tracks_apart(cls, gauge, info: ValidationInfo):
        width = info.data.get("width_m")
        if gauge is not None and width is not None and gauge <= width:
            raise ValueError(f"the tracks' centres must be more than their width B = {width:g} m apart")
        return gauge


class StripGeometry(BodyConfig):
    """A rigid strip footing of width B; plane strain per metre of length by default."""

    kind: Literal["strip"]


class TbarGeometry(BodyConfig):
    """A rigid cylinder of diameter B (``width_m``): a T-bar penetrometer in plane strain, a ball
    in axisymmetry. ``landing.initial_depth_m`` is the depth of its lowest point."""

    kind: Literal["tbar"]


class ConeGeometry(BodyConfig):
    """A fall cone (axisymmetric): apex angle, tip down; ``width_m`` is its diameter at the top."""

    kind: Literal["cone"]
    apex_angle_deg: Number = Field(gt=0, lt=180, description="full apex angle (degrees)")
    contact_length_m: Optional[Number] = Field(None, description="not used by a cone")

    @property
    def contact_area_m2(self) -> float:
        return math.pi * self.width_m**2 / 4


class RectangularPlateGeometry(BodyConfig):
    """A rigid rectangular plate, width B (``width_m``) by length L (``contact_length_m``); B = L is a
    square. A 3D body (``solver=cel3d``)."""

    kind: Literal["rectangular_plate"]


class CircularPlateGeometry(BodyConfig):
    """A rigid circular plate of diameter B (``width_m``). A 3D body (``solver=cel3d``)."""

    kind: Literal["circular_plate"]
    contact_length_m: Optional[Number] = Field(None, description="not used by a circular plate")

    @property
    def contact_area_m2(self) -> float:
        return math.pi * self.width_m**2 / 4


GEOMETRY_KINDS: dict[str, type[BodyConfig]] = {
    "track": TrackGeometry, "strip": StripGeometry, "tbar": TbarGeometry, "cone": ConeGeometry,
    "rectangular_plate": RectangularPlateGeometry, "circular_plate": CircularPlateGeometry,
}

# --------------------------------------------------------------------------- landing


#: the rigid body's freedoms, as ``landing.free`` names them (translations, then rotations about x, y, z)
FREEDOM_NAMES = ("x", "y", "z", "rx", "ry", "rz")
#: the landing keys of the freedoms beyond the vertical, at the values that keep a body vertical
VERTICAL_LANDING = {"free": None, "horizontal_velocity_m_s": 0.0, "lateral_velocity_m_s": 0.0, "roll_rate_rad_s": 0.0,
                    "pitch_rate_rad_s": 0.0, "yaw_rate_rad_s": 0.0, "rotation_deg": None, "cg_offset_m": [0.0, 0.0, 0.0],
                    "rotational_inertia_kg_m2": None, "cycles": 0, "stroke_m": None, "pitch_deg": 0.0,
                    "roll_deg": 0.0}
#: the landing key of each freedom's given speed (z's is downward)
RATE_KEYS = {"x": "horizontal_velocity_m_s", "y": "lateral_velocity_m_s", "z": "velocity_m_s",
             "rx": "pitch_rate_rad_s", "ry": "roll_rate_rad_s", "rz": "yaw_rate_rad_s"}


class LandingConfig(Schema):
    """How the body meets the soil.

    ``drop``: free landing at ``velocity_m_s`` under the wet weight m·g; the study uses the
    wet weight m for inertia too (``inertial_mass_kg`` overrides that).
    ``push``: prescribed downward velocity to ``displacement_m`` (load–displacement curves).
    The weight is shared by ``n_tracks`` tracks; one track is modelled.

    The body's freedoms (x across it, y along it, z up; rx pitch, ry roll, rz yaw about them; a
    plane-strain model has x, z and ry): those in ``free`` move under the soil's reaction (a drop's z
    always), the others keep their given speed (``velocity_m_s`` down, ``horizontal_velocity_m_s``,
    ``lateral_velocity_m_s``, ``pitch_rate_rad_s``, ``roll_rate_rad_s``, ``yaw_rate_rad_s``; 0: held).
    The centre of gravity sits ``cg_offset_m`` (x, y, z) from the middle of the body's base.
    """

    kind: Literal["drop", "push"]
    mass_kg: Number = Field(gt=0, description="wet weight as a mass m (kg), the study's m")
    velocity_m_s: Number = Field(ge=0, description="downward velocity at touchdown / of the push (m/s)")
    n_tracks: Count = Field(1, ge=1, description="tracks sharing the weight (-)")
    inertial_mass_kg: Optional[Number] = Field(None, gt=0, description="mass for inertia (kg); default m")
    gravity_m_s2: Number = Field(9.81, ge=0, description="gravitational acceleration (m/s²)")
    displacement_m: Optional[Number] = Field(None, gt=0, description="push: displacement to reach (m)")
    initial_depth_m: Number = Field(0.0, ge=0, description="depth of the body's base below the mudline at the start (m)")
    free: Optional[list[Literal[FREEDOM_NAMES]]] = Field(None, description=(
        "freedoms that move under the soil's reaction; null: z for a drop, none for a push"))
    horizontal_velocity_m_s: Number = Field(0.0, description="velocity along +x, across the body (m/s)")
    lateral_velocity_m_s: Number = Field(0.0, description="velocity along +y, along the body (m/s)")
    pitch_rate_rad_s: Number = Field(0.0, description="rotation rate about x (rad/s; + raises the +y end)")
    roll_rate_rad_s: Number = Field(0.0, description="rotation rate about y (rad/s; + lowers the +x side)")
    yaw_rate_rad_s: Number = Field(0.0, description="rotation rate about z (rad/s; + turns +x towards +y)")
    pitch_deg: Number = Field(0.0, gt=-30, lt=30, description=(
        "attitude at first contact about x (degrees; + raises the +y end): the body touches the mudline "
        "with its lowest point"))
    roll_deg: Number = Field(0.0, gt=-30, lt=30, description="attitude at first contact about y (degrees; + lowers the +x side)")
    rotation_deg: Optional[Number] = Field(None, gt=0, description="push: rotation to reach (degrees)")
    cg_offset_m: list[Number] = Field([0.0, 0.0, 0.0], min_length=3, max_length=3, description=(
        "the centre of gravity's offset (x, y, z) from the middle of the body's base (m)"))
    rotational_inertia_kg_m2: Optional[list[Number]] = Field(None, min_length=3, max_length=3, description=(
        "inertia about x, y and z through the centre of gravity, per track (kg·m²); null: a uniform box of "
        "the body's size"))
    cycles: Count = Field(0, ge=0, description=(
        "push: after reaching displacement_m, strokes up stroke_m and back down this many times (a cyclic "
        "T-bar test); 0: none"))
    stroke_m: Optional[Number] = Field(None, gt=0, description="push with cycles: the stroke's length (m)")

    @model_validator(mode="after")
    def _motion_is_complete(self):
        if self.free is not None and len(set(self.free)) < len(self.free):
            raise ConfigError("landing.free", self.free, "names a freedom twice")
        if self.rotational_inertia_kg_m2 is not None and min(self.rotational_inertia_kg_m2) <= 0:
            raise ConfigError("landing.rotational_inertia_kg_m2", self.rotational_inertia_kg_m2, "must be > 0 (kg·m²)")
        if self.kind == "drop" and "z" not in self.freedoms:
            raise ConfigError("landing.free", self.free, "a drop falls free: include z (a body held in z is a push)")
        if self.kind == "push":
            driven = self.driven
            if not driven:
                raise ConfigError("landing.velocity_m_s", self.velocity_m_s, "a push needs a velocity > 0 (m/s), "
                                  "or another speed or rate on a freedom it holds")
            if driven & {"x", "y", "z"} and self.displacement_m is None:
                raise ConfigError("landing.displacement_m", None, "a push needs a displacement > 0 (m)")
            if not driven & {"x", "y", "z"} and self.rotation_deg is None:
                raise ConfigError("landing.rotation_deg", None, "a push that only turns needs a rotation > 0 (degrees)")
        if self.cycles:
            if self.kind != "push" or self.driven != {"z"} or self.freedoms:
                raise ConfigError("landing.cycles", self.cycles, "cycles are a vertical push's (landing=push, driven "
                                  "in z only, nothing free)")
            if self.stroke_m is None or self.stroke_m > self.displacement_m:
                raise ConfigError("landing.stroke_m", self.stroke_m, "cycles need a stroke > 0 no longer than "
                                  f"the displacement ({self.displacement_m:g} m)")
        return self

    @property
    def freedoms(self) -> tuple[str, ...]:
        """The freedoms that move under the soil's reaction: ``free``, or z for a drop and none for a push."""
        if self.free is not None:
            return tuple(self.free)
        return ("z",) if self.kind == "drop" else ()

    def given_velocity(self, name: str) -> float:
        """The speed given to a freedom (m/s or rad/s, the body's axes: z up +)."""
        rate = getattr(self, RATE_KEYS[name])
        return -rate if name == "z" else rate

    @property
    def driven(self) -> set[str]:
        """The freedoms a push drives: those with a speed that do not move under the soil."""
        return {n for n in FREEDOM_NAMES if self.given_velocity(n) != 0 and n not in self.freedoms}

    @property
    def push_duration_s(self) -> float:
        """How long a push lasts (s): its displacement over the speed of the translations it drives, or its
        rotation over its rate, whichever ends it first."""
        driven = self.driven
        speed = math.sqrt(sum(self.given_velocity(n) ** 2 for n in ("x", "y", "z") if n in driven))
        travel = (self.displacement_m or 0.0) + 2.0 * self.cycles * (self.stroke_m or 0.0)
        ends = [travel / speed] if speed > 0 and self.displacement_m else []
        rate = math.sqrt(sum(self.given_velocity(n) ** 2 for n in ("rx", "ry", "rz") if n in driven))
        if rate > 0 and self.rotation_deg:
            ends.append(math.radians(self.rotation_deg) / rate)
        return min(ends)

    def symmetric_about(self, axis: str) -> bool:
        """Whether the landing is mirror-symmetric about the body's vertical mid-plane normal to ``axis``
        (x: the plane along the body; y: across it): no drift across the plane, no turn that tilts or
        twists it, the centre of gravity on it. A symmetric body then moves as its mirror image does,
        whatever freedoms it has."""
        across, tilt = ("x", "ry") if axis == "x" else ("y", "rx")
        return (self.given_velocity(across) == 0 and self.given_velocity(tilt) == 0
                and self.given_velocity("rz") == 0 and self.cg_offset_m["xy".index(axis)] == 0
                and self.attitude_rad[FREEDOM_NAMES.index(tilt) - 3] == 0)

    @property
    def symmetric(self) -> bool:
        """Symmetric about both vertical mid-planes (:meth:`symmetric_about`)."""
        return self.symmetric_about("x") and self.symmetric_about("y")

    @property
    def beyond_vertical_key(self) -> Optional[str]:
        """The first landing key that lets the body slide or turn (a freedom, a speed, the centre of
        gravity off the axis), or None."""
        if set(self.freedoms) - {"z"}:
            return "landing.free"
        rate = next((RATE_KEYS[n] for n in FREEDOM_NAMES if n != "z" and self.given_velocity(n)), None)
        if rate:
            return f"landing.{rate}"
        if self.attitude_key:
            return self.attitude_key
        return "landing.cg_offset_m" if any(self.cg_offset_m[:2]) else None

    @property
    def attitude_rad(self) -> tuple[float, float, float]:
        """The body's attitude at first contact, about x, y and z (rad): ``pitch_deg``, ``roll_deg``, 0."""
        return math.radians(self.pitch_deg), math.radians(self.roll_deg), 0.0

    @property
    def attitude_key(self) -> Optional[str]:
        """The first landing key that tilts the body at first contact, or None: it touches down level."""
        return next((f"landing.{key}" for key in ("pitch_deg", "roll_deg") if getattr(self, key)), None)

    @property
    def turn_key(self) -> Optional[str]:
        """The first landing key that lets the body turn (a rotation among the free freedoms, a rotation
        rate), or None: a body that only slides keeps its attitude."""
        if set(self.freedoms) & {"rx", "ry", "rz"}:
            return "landing.free"
        return next((f"landing.{RATE_KEYS[n]}" for n in ("rx", "ry", "rz") if self.given_velocity(n)), None)

    @property
    def moves_beyond_vertical(self) -> bool:
        """Whether the body may slide or turn: a freedom other than z, or a speed on one, or its centre of
        gravity off its axis."""
        return bool(set(self.freedoms) - {"z"}) or not self.symmetric

    @property
    def weight_per_track_n(self) -> float:
        """Wet weight carried by one track, m·g/n (N)."""
        return self.mass_kg * self.gravity_m_s2 / self.n_tracks

    @property
    def inertia_per_track_kg(self) -> float:
        """Mass accelerated with one track (kg)."""
        return (self.inertial_mass_kg or self.mass_kg) / self.n_tracks


# --------------------------------------------------------------------------- mesh, output


#: the mesh option that stands for the solver's default mesh (:func:`settle_mesh`)
AUTO_MESH = "auto"


class MeshConfig(Schema):
    """Eulerian grid: uniform core cells, graded geometrically towards the far boundaries."""

    name: str
    cell_size_m: Number = Field(gt=0, description="core cell size h (m)")
    max_cell_size_m: Number = Field(gt=0, description="largest cell at the far boundaries (m)")
    growth_ratio: Number = Field(ge=1.0, le=1.5, description="size ratio of neighbouring graded cells (-)")

    @model_validator(mode="after")
    def _max_not_below_core(self):
        if self.max_cell_size_m < self.cell_size_m:
            raise ConfigError(
                "mesh.max_cell_size_m", self.max_cell_size_m, f"must be ≥ mesh.cell_size_m = {self.cell_size_m} m"
            )
        return self


class OutputConfig(Schema):
    """What a run writes besides result.json and the history CSV (see :mod:`dsmv.cel.fields`)."""

    plots: bool = Field(True, description="history.png; with fields, the contour PNG too")
    fields: bool = Field(False, description="CEL: fields.pvd and fields/*.vtu for ParaView")
    field_frames: Count = Field(20, ge=1, description="evenly spaced frames: N to 2N of them, plus the deepest (-)")


class SafetyConfig(Schema):
    """The limits a landing is judged against (``safety``; null: not judged; :mod:`dsmv.safety`)."""

    max_sinkage_m: Optional[Number] = Field(None, gt=0, description="deepest sinkage allowed (m)")
    max_tilt_deg: Optional[Number] = Field(None, gt=0, description="largest rotation allowed (°)")
    max_slide_m: Optional[Number] = Field(None, gt=0, description="largest horizontal displacement allowed (m)")
    max_deceleration_g: Optional[Number] = Field(None, gt=0, description="hardest stop allowed (g)")


#: the sweep-level plots an experiment can ask for with ``sweep_plot: <name>`` (drawn by
#: :data:`dsmv.post.plots.SWEEP_PLOT_MAKERS`)
SWEEP_PLOTS = ("fall_cone", "one_at_a_time", "compare_analytic", "mesh_study", "section_factors", "bearing_curves",
               "green_envelope", "safe_region", "vehicle_response", "per_vehicle")


class TrackingConfig(Schema):
    """MLflow tracking: a local SQLite store by default."""

    enabled: bool
    uri: Optional[str] = None
    artifact_location: Optional[str] = None

    @model_validator(mode="after")
    def _uri_when_enabled(self):
        if self.enabled and not self.uri:
            raise ConfigError("tracking.uri", self.uri, "tracking is enabled: give a store URI "
                                                        "(sqlite:///…, http://127.0.0.1:5000) or use tracking=disabled")
        return self


# --------------------------------------------------------------------------- scene

#: solver settings that change how a run is shown or sampled, never its result
RESULT_NEUTRAL_SOLVER_KEYS = {"progress", "history_samples", "max_steps", "max_wall_s"}


@dataclass(frozen=True)
class Scene:
    """A validated scene: soil × body × landing × mesh × solver."""

    study: str
    soil: SoilConfig
    geometry: BodyConfig
    landing: LandingConfig
    mesh: MeshConfig
    solver: BaseModel
    output: OutputConfig
    safety: SafetyConfig = SafetyConfig()

    @property
    def config_hash(self) -> str:
        """Short SHA-256 of the physics-relevant config: same scene, same hash."""
        text = json.dumps(self.physics_dict(), sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    @property
    def label(self) -> str:
        """The scene in one phrase, with units: soil, law, body and landing (the run's summary, its history
        plot's title and its MLflow tag ``dsmv.scene``)."""
        landing = self.landing
        motion = (f"push to {landing.displacement_m:g} m at {landing.velocity_m_s:g} m/s" if landing.kind == "push"
                  else f"{landing.kind} {landing.mass_kg:g} kg at {landing.velocity_m_s:g} m/s")
        if landing.kind == "push" and landing.driven - {"z"}:  # a push along or about another axis
            speeds = [f"down {landing.velocity_m_s:g} m/s" if n == "z" else
                      f"{n} {landing.given_velocity(n):g} {'m/s' if len(n) == 1 else 'rad/s'}"
                      for n in FREEDOM_NAMES if n in landing.driven]
            ends = [f"{landing.displacement_m:g} m" if landing.driven & {"x", "y", "z"} else "",
                    f"{landing.rotation_deg:g}°" if landing.rotation_deg and landing.driven & {"rx", "ry", "rz"} else ""]
            motion = f"push to {' or '.join(e for e in ends if e)} at {', '.join(speeds)}"
        if set(landing.freedoms) - {"z"} or landing.kind == "push" and landing.freedoms:
            motion += f", free in {', '.join(landing.freedoms)}"
        if any(landing.cg_offset_m):
            motion += f", centre of gravity {tuple(landing.cg_offset_m)} m off"
        if landing.attitude_key:
            motion += ", touching down " + " and ".join(f"{word} {angle:g}°" for word, angle in (
                ("pitched", landing.pitch_deg), ("rolled", landing.roll_deg)) if angle)
        body = self.geometry.name
        if self.geometry.vehicle:
            body += f" (two tracks {self.geometry.gauge_m:g} m apart, each carrying half)"
        seabed = (f" on a {self.soil.slope_deg:g}° slope falling towards {self.soil.downslope_direction_deg:g}° from +x"
                  if self.soil.slope_deg else "")
        return f"{self.soil.name} soil ({self.soil.law}){seabed}, {body}, {motion}"

    def physics_dict(self) -> dict[str, Any]:
        """What decides a result (what the hash covers), as plain data: display settings excluded."""
        return {
            # a soil without a table keeps the hash it had before tables existed
            # (and on a level seabed, the hash it had before slopes existed)
            "soil": {k: v for k, v in self.soil.model_dump().items() if not (
                (k == "profile" and v is None) or (k == "profile_scale" and v == 1.0)
                or (k in ("slope_deg", "downslope_direction_deg") and self.soil.slope_deg == 0))},
            # a lone track keeps the hash it had before vehicles existed
            # (and a section on its plates, the hash it had before sections at the grousers' tips existed)
            "geometry": {k: v for k, v in self.geometry.model_dump().items()
                         if not ((k == "gauge_m" and v is None) or (k == "section_base" and v == "plates"))},
            # the keys of the body's other freedoms count once they differ from a vertical landing's,
            # so a vertical scene keeps the hash it had before they existed (its runs still resume)
            "landing": {k: v for k, v in self.landing.model_dump().items()
                        if k not in VERTICAL_LANDING or v != VERTICAL_LANDING[k]},
            "mesh": self.mesh.model_dump(),
            # how often a turning body is redrawn counts for a body that turns only
            "solver": self.solver.model_dump(exclude=RESULT_NEUTRAL_SOLVER_KEYS | (
                set() if self.landing.turn_key else {"redraw_fraction"})),
        }


def _law_parameters(law_cls, soil: SoilConfig) -> SoilConfig:
    """``soil.params`` validated against the law's declared parameters (``parameters_model``), with the
    defaults filled in (so the config hash covers them); unchanged for a law that declares none."""
    model = getattr(law_cls, "parameters_model", None)
    if model is None:
        return soil
    params = _validate(model, dict(soil.params), "soil.params")
    return soil.model_copy(update={"params": params.model_dump()})


def _group(container: dict, name: str) -> Any:
    if name not in container:
        raise ConfigError(name, None, "missing config group")
    return container[name]


def settle_mesh(cfg: DictConfig | dict, mesh: Any, solver_cls) -> Any:
    """``mesh=auto`` (the default): the solver's own default mesh (its plugin's ``default_mesh``: cel2d
    ``standard``, cel3d ``coarse``; ``standard`` for a solver that names none), any key the user set
    kept. A composed config gets the settled values too, so that its resolved copy, its tracked
    params and its hash name the mesh that ran."""
    if not isinstance(mesh, dict) or mesh.get("name") != AUTO_MESH:
        return mesh
    name = getattr(solver_cls, "default_mesh", "standard")
    default = OmegaConf.to_container(OmegaConf.load(Path(CONFIG_DIR) / "mesh" / f"{name}.yaml"))
    chosen = {key: value for key, value in mesh.items() if value is not None and key != "name"}
    settled = default | chosen | ({"name": "custom"} if chosen else {})
    if isinstance(cfg, DictConfig):
        with open_dict(cfg):
            cfg.mesh = settled
    return settled


def check_slope(scene: Scene, solver_cls) -> None:
    """A sloping seabed: in a solver that takes it (``takes_slope``: the CEL's, the level grid with gravity
    turned), and standing (its infinite slope does not fail under its own weight down to what the model
    takes in)."""
    soil = scene.soil
    if soil.slope_deg == 0:
        return
    takes_slope = getattr(solver_cls, "takes_slope", False)
    if not (takes_slope(scene) if callable(takes_slope) else takes_slope):
        raise ConfigError("soil.slope_deg", soil.slope_deg, "a sloping seabed runs in cel2d and cel3d (the level "
                          f"grid with gravity turned); {scene.solver.name} lands on a level one")
    # the soil the model holds below the body, and what enters at its base as the body sinks a width (a model
    # without a grid: the 3D CEL's default domain's)
    depth_widths = getattr(scene.solver, "domain_depth_widths", None)
    if depth_widths is None:
        depth_widths = OmegaConf.load(Path(CONFIG_DIR) / "solver" / "cel3d.yaml").domain_depth_widths
    modelled = scene.landing.initial_depth_m + (depth_widths + 1.0) * scene.geometry.width_m
    steepest = soil.steepest_slope_deg(scene.landing.gravity_m_s2, modelled)
    if soil.slope_deg > steepest:
        raise ConfigError("soil.slope_deg", soil.slope_deg, f"the seabed would slide: as an infinite slope its weight "
                          f"(ρ'·g·sinβ·d) shears it past su within the {modelled:.3g} m of soil the model takes in; "
                          f"this soil stands up to {steepest:.3g}°")


def build_scene(cfg: DictConfig | dict) -> Scene:
    """Validate a composed config into a :class:`Scene` (raises ConfigError on the first bad value)."""
    container = _to_container(cfg) if isinstance(cfg, DictConfig) else dict(cfg)

    soil = _validate(SoilConfig, _group(container, "soil"), "soil")
    soil = _law_parameters(registry.load("soil_laws", soil.law, "soil.law"), soil)

    geometry_data = _group(container, "geometry")
    kind = geometry_data.get("kind") if isinstance(geometry_data, dict) else None
    if kind not in GEOMETRY_KINDS:
        raise ConfigError("geometry.kind", kind, f"must be one of {', '.join(GEOMETRY_KINDS)}")
    geometry = _validate(GEOMETRY_KINDS[kind], geometry_data, "geometry")

    landing = _validate(LandingConfig, _group(container, "landing"), "landing")

    solver_data = _group(container, "solver")
    solver_name = solver_data.get("name") if isinstance(solver_data, dict) else None
    solver_cls = registry.load("solvers", solver_name, "solver.name")
    solver = _validate(solver_cls.config_model, solver_data, "solver")
    mesh = _validate(MeshConfig, settle_mesh(cfg, _group(container, "mesh"), solver_cls), "mesh")

    output = _validate(OutputConfig, container.get("output", {}), "output")
    safety = _validate(SafetyConfig, container.get("safety") or {}, "safety")
    study = str(container.get("study", "default"))
    if not isinstance(container.get("resume", False), bool):
        raise ConfigError("resume", container["resume"], "must be true or false")
    if container.get("sweep_plot") not in (None, *SWEEP_PLOTS):
        raise ConfigError("sweep_plot", container["sweep_plot"], f"must be null or one of {', '.join(SWEEP_PLOTS)}")

    objective_config(container)  # not part of the scene either: a wrong objective fails before the run
    build_tracking(cfg)  # not part of the scene, but a wrong store fails here too
    if geometry.vehicle and landing.n_tracks != 2:
        raise ConfigError("landing.n_tracks", landing.n_tracks, f"a vehicle ({geometry.name}: geometry.gauge_m set) "
                          "stands on two tracks that share its weight: 2")
    if getattr(geometry, "section_base", "plates") == "grouser_tips" and not solver.name.startswith("cel2d"):
        raise ConfigError("geometry.section_base", geometry.section_base, "a section at the grousers' tips is cel2d's: "
                          "cel3d models the grousers' envelope itself, the fast models count grousers by solver.grousers")
    scene = Scene(study, soil, geometry, landing, mesh, solver, output, safety)
    check_touchdown_speed(scene)
    check_slope(scene, solver_cls)
    if geometry.kind in getattr(solver_cls, "bodies", ()):  # a solver that meshes the body
        check_core_cells(scene)
    check = getattr(solver_cls, "check_scene", None)
    if check is not None:  # what this solver cannot run fails here, not halfway through a run
        check(scene)
    return scene


#: the fastest touchdown or push allowed, as a fraction of the soil's elastic wave speed
MAX_SPEED_FRACTION = 0.1


def elastic_wave_speed_m_s(soil: SoilConfig) -> float:
    """The soil's elastic (P-) wave speed c = √((K + 4G/3)/ρ) (m/s), K = E/(3(1 − 2ν)), G = E/(2(1 + ν)),
    ρ the soil's density as the model has it (``soil.density_kg_m3``)."""
    E, nu = soil.youngs_modulus_pa, soil.poisson_ratio
    bulk, shear = E / (3.0 * (1.0 - 2.0 * nu)), E / (2.0 * (1.0 + nu))
    return math.sqrt((bulk + 4.0 * shear / 3.0) / soil.density_kg_m3)


def check_touchdown_speed(scene: Scene) -> None:
    """A body meeting the soil at a sizeable fraction of its wave speed drives a shock into it, which
    neither the energy method nor the CEL soil model describes: refuse above MAX_SPEED_FRACTION · c."""
    c = elastic_wave_speed_m_s(scene.soil)
    limit = MAX_SPEED_FRACTION * c
    if scene.landing.velocity_m_s > limit:
        raise ConfigError("landing.velocity_m_s", scene.landing.velocity_m_s,
                          f"must be at most {limit:.4g} m/s, a tenth of the soil's elastic wave speed "
                          f"c = √((K + 4G/3)/ρ) = {c:.4g} m/s (from soil.youngs_modulus_pa, soil.poisson_ratio "
                          f"and soil.density_kg_m3)")


def check_core_cells(scene: Scene) -> None:
    """Core cells of more than half the body's width cannot resolve it (a mesh solver would silently put
    one cell across its half width). A cone is exempt: its cells are sized to its expected penetration."""
    body = scene.geometry
    if body.kind == "cone":
        return
    if getattr(body, "view", "cross_section") == "longitudinal":
        key, width = "geometry.contact_length_m", body.contact_length_m
    else:
        key, width = "geometry.width_m", body.width_m
    if scene.mesh.cell_size_m > 0.5 * width:
        raise ConfigError("mesh.cell_size_m", scene.mesh.cell_size_m,
                          f"must be at most {0.5 * width:.4g} m, half the body's width ({key} = {width:g} m): "
                          f"coarser core cells cannot resolve the body")


def build_tracking(cfg: DictConfig | dict) -> TrackingConfig:
    """Validate the ``tracking`` group."""
    # Resolve only this node: the rest (hydra.*) may not resolve outside a job.
    data = _resolve(cfg.get("tracking", {"enabled": False}))
    return _validate(TrackingConfig, data, "tracking")

