"""Config of the CEL solvers: numerical settings only; the physics comes from the scene.

``CelConfig`` holds what every dimension shares; ``Cel2DConfig`` adds the 2D mode. The schema says
what each key means and allows; the values, defaults included, live in one home, the solver's YAML
(``conf/solver/cel2d.yaml``): every field is required, so a YAML that misses one fails at once.
:func:`solver_defaults` reads them for code that runs without a composed scene.
"""

from __future__ import annotations

from typing import Literal, Optional, Union

from pydantic import Field, field_validator

from dsmv.config.schema import Count, Number, Schema


class Economies(Schema):
    """Work the solver skips; each can be switched off only to measure what it saves (dsmv-bench)."""

    skip_inactive_law: bool = Field(description="a law without softening or rate skips that arithmetic")
    stop_at_rest: bool = Field(description="a landing ends when the body first comes to rest; "
                                           "false: it runs on to twice that time")
    skip_void: bool = Field(description="cells without soil do no force arithmetic")
    symmetry: bool = Field(description="model half the section, with a symmetry plane on the body's axis "
                                       "(true or 'half'); false or 'full': the whole section (plane strain, rough "
                                       "contact)")

    @field_validator("symmetry", mode="before")
    @classmethod
    def _half_or_full(cls, value):
        """'half' and 'full', the 3D solver's words, name the 2D models too (a 3D config keeps its words)."""
        if cls.model_fields["symmetry"].annotation is not bool or not isinstance(value, str):
            return value
        return {"half": True, "full": False}.get(value, value)


class CelConfig(Schema):
    """What every CEL solver is set with (numerical settings; the physics comes from the scene)."""

    cfl: Number = Field(gt=0, le=1, description="time step as a fraction of the CFL limit (-)")
    hourglass: Number = Field(ge=0, le=1, description="viscous hourglass coefficient (-)")
    hourglass_region: Literal["auto", "cut_cells", "everywhere"] = Field(description=(
        "cut_cells: the hourglass force acts only in the cells a curved body cuts and their neighbours; "
        "everywhere: in every cell; auto: cut_cells, but everywhere for the fall cone, whose staircase "
        "gathers the zig-zag"))

    bulk_viscosity_linear: Number = Field(ge=0, description="linear bulk viscosity b1 (-)")
    bulk_viscosity_quadratic: Number = Field(ge=0, description="quadratic bulk viscosity b2 (-)")
    advection_order: Literal[1, 2] = Field(description="1: donor cell, 2: van Leer MUSCL")
    yield_surface: Literal["auto", "tresca", "von_mises"] = Field(
        description="auto: von Mises (J2) in plane strain, where it equals Tresca; Tresca in axisymmetry")
    stress_cutoff: Number = Field(ge=0, lt=1, description="cells with less soil carry no stress (-)")
    remap: bool = Field(description="false: small-strain analysis on the undeformed grid (verification)")
    contact_separation: Union[bool, Literal["auto"]] = Field(description=(
        "auto: on for a landing (landing=drop) wherever the faces can let go, else off; true: a face lets "
        "go of the soil that would pull away from it (no tension); false: the soil stays tied to it"))
    # at most 0.25: next to the axis of an axisymmetric model a cell's volume Courant number is
    # about twice the travel over h
    remap_courant: Number = Field(ge=0, le=0.25, description=(
        "the remap runs once the soil has moved this fraction of a core cell through the grid; 0: every step (-)"))
    domain_depth_widths: Number = Field(ge=1, description="soil depth below the body, in body widths B")
    domain_half_width_widths: Number = Field(ge=1, description="half-width of the domain, in B")
    core_margin_widths: Number = Field(gt=0, description="uniform core beyond the body, in B")
    history_samples: Count = Field(ge=10, description="samples in the time history (-)")
    max_steps: Count = Field(ge=1, description="steps before a run gives up (-)")
    error_estimate: bool = Field(description=(
        "true: run the scene on cells h, 2h and 4h too, and report the answer's mesh error (Richardson)"))
    max_wall_s: Number = Field(gt=0, description=(
        "refuse a run whose estimated wall time exceeds this (s); it never changes a result"))
    progress: Literal["auto", "on", "off"] = Field(description=(
        "auto: outside sweeps, a bar on a terminal and a plain line every 10 s in a log or pipe"))
    initial_travel_m: Optional[Number] = Field(gt=0, description="travel to size the domain for (m)")
    cone_cells_per_depth: Count = Field(ge=4, description="cone: core cells across the expected penetration")
    redraw_fraction: Number = Field(0.25, ge=0, le=1, description=(
        "a body that turns with the remap is redrawn once its farthest point has moved this fraction of a core "
        "cell past its drawing; 0: after every history sample (-)"))
    economies: Economies

    def hourglass_cells(self, body_kind: str) -> str:
        """Where the hourglass force acts for a body of this kind: ``auto`` resolved (decision 0016)."""
        if self.hourglass_region != "auto":
            return self.hourglass_region
        return "everywhere" if body_kind == "cone" else "cut_cells"


class Cel2DConfig(CelConfig):
    """Config of ``solver=cel2d``."""

    name: Literal["cel2d"]
    mode: Literal["auto", "plane_strain", "axisymmetric"] = Field(description="auto: from the geometry")


class Economies3D(Economies):
    """A 3D solver's economies: the symmetry planes it models."""

    symmetry: Literal["quarter", "half", "full"] = Field(description=(
        "quarter: a quarter of the body, two vertical symmetry planes through its axes; half: one plane, "
        "across the body (x = 0); full: the whole body. A strip slab lies between two plane-strain "
        "planes: quarter and half model half its section"))


class Cel3DConfig(CelConfig):
    """Config of ``solver=cel3d``."""

    name: Literal["cel3d"]
    threads: Optional[Count] = Field(ge=1, description=(
        "threads of the per-cell kernels; null: all cores outside sweeps, 1 in a sweep's job (-)"))
    economies: Economies3D


def solver_defaults(name: str) -> dict:
    """The settings of ``conf/solver/<name>.yaml``, the one home of a solver's defaults."""
    from pathlib import Path

    from omegaconf import OmegaConf

    from dsmv.config.tree import CONFIG_DIR

    return OmegaConf.to_container(OmegaConf.load(Path(CONFIG_DIR) / "solver" / f"{name}.yaml"), resolve=True)
