"""The explicit Coupled Eulerian–Lagrangian solver, as every dimension runs it: :class:`CelSolver`.

Soil lives on a rectilinear Eulerian grid with a volume fraction per cell; the body is rigid.
The grid translates with the body (what Abaqus/Explicit calls Eulerian mesh motion), so the
body's boundary always lies on the same grid lines. Contact is then a kinematic tie of a
fixed set of nodes (rough: both velocity components, smooth: the normal one), and the
cell-crossing noise and partly filled cells under the body, the largest errors of a
fixed-grid prototype (DESIGN.md §5), cannot arise. The price: in the grid frame the far
soil streams upwards, so soil enters through the base, intact and geostatic at the depth it
has there; the base stays at a fixed distance below the body (set by
``solver.domain_depth_widths``), and the mass audit counts what entered.

:class:`CelSolver` knows no dimension: domain sizing, the contact rules, the initial state, the
controller and its trackers, the energy ledger and the result. :class:`~dsmv.cel.solver2d.Cel2DSolver`
and :class:`~dsmv.cel.solver3d.Cel3DSolver` give the grid, the body's contact, the mesh and faces,
and their dimension's kernels (:func:`~dsmv.cel.kernels.for_dimension`).
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass, replace
from functools import cached_property
from typing import Optional

import numpy as np

from dsmv import registry
from dsmv.analytic.dynamic import fast_landing, fast_vehicle
from dsmv.analytic.landing_model import REST_OUT_OF_BALANCE, REST_SPEED_AFTER_FALL
from dsmv.analytic.energy import energy_estimate, sinkage_in_profile
from dsmv.cel import controller as C
from dsmv.cel import cost as cost_model
from dsmv.cel import ledger
from dsmv.cel.config import CelConfig
from dsmv.cel.contact import ContactRules
from dsmv.cel.grid import axis_through
from dsmv.cel.kernels import DimensionKernels, for_dimension
from dsmv.cel.layout import (
    B_INFLOW, B_MAXDISP, B_MAXEDGE, B_MAXROT, B_MAXSLIDE, B_ROT_X, B_ROT_Z, B_SINKAGE, B_TIME, B_VEL, FORCE_SLOTS,
    FREEDOMS, N_BODY, POSE_SLOTS, VELOCITY_SLOTS, CellRows, Cells, Inflow, Nodes, Params, SoilLawKernel, freedom_mask,
)
from dsmv.cel.state import Elastic, density_ratios, geostatic_state, hourglass_factor, step_parameters, weighed_soil
from dsmv.errors import ConfigError
from dsmv.results import SolveResult, add_plate_sinkage, add_vehicle_answers
from dsmv.config.scene import FREEDOM_NAMES, RATE_KEYS, Scene
from dsmv.config.profile import weighed

#: s/B at which push curves are sampled for the bearing factor q/su0 (averaged over ±0.005·B)
NC_SAMPLES = {"nc_at_0p02B": 0.02, "nc_at_0p05B": 0.05, "nc_at_0p1B": 0.1, "nc_at_1B": 1.0}
NC_WINDOW = 0.005
#: an 'ok' run's energy audit must close to this (relative); worse means the numerics failed
ENERGY_ERROR_LIMIT = 0.05
#: memory per cell of the 2D state (B): the cell state (six stress, strain and depth rows and
#: the law's), φ, strength, factors, openings, gap and merge fields, the face fluxes and apertures,
#: the corner table, and the nodes' velocity, force, travel and mass
BYTES_PER_CELL = 8 * (6 + 7 + 4 + 7) + 16
#: memory per cell of one field frame (B): φ, q, su, the strain rate and the nodes' velocity
BYTES_PER_FRAME_CELL = 8 * (1 + 6 + 2 + 2)
#: the zig-zag diagnostic counts cells at least this full: a partly filled cell at the soil's
#: surface has void nodes, which stand still, and would read as zig-zag
ZIGZAG_FULL_CELL = 0.99


def available_memory_b() -> float:
    """The memory this machine has free (B): MemAvailable from /proc/meminfo, else unbounded."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024.0
    except OSError:
        pass
    return math.inf


def in_sweep() -> bool:
    """True inside a Hydra multirun job: progress lines of many jobs would only interleave."""
    from hydra.core.hydra_config import HydraConfig
    from hydra.types import RunMode

    return HydraConfig.initialized() and HydraConfig.get().mode == RunMode.MULTIRUN


@dataclass
class State:
    """A run's state: the grid, the containers the compiled loop takes, and what set-up measured."""

    grid: object
    mesh: object           # Mesh2D or Mesh3D
    cells: Cells
    faces: object          # Faces2D or Faces3D
    nodes: Nodes
    contact: object
    inflow: Inflow
    par: object
    body: np.ndarray
    energy: np.ndarray
    law: object            # the soil law's kernel (SoilLawKernel), None for a law without effect or state
    scale: float           # model quantities → per track
    mass0: float           # soil mass at the start (kg, model)
    elastic0: float        # elastic energy at the start (J, model)
    touchdown_loss: float  # kinetic energy lost at touchdown (J, model)
    kinetic_in: float      # the body's kinetic energy at touchdown (J, model)
    stepper: object = None  # the compiled loop's machine code for these containers (CelSolver.advance)


@dataclass(frozen=True)
class Start:
    """The body at the start of a landing, per track."""

    depth_m: float          # its base below the mudline
    velocity_m_s: float     # downward
    inertia_kg: float
    weight_n: float
    sinkage_m: float        # the sinkage it has already (a trapped-soil track's grouser height)


class CelSolver:
    """What every CEL solver shares: set-up → touchdown → controller → ledger → SolveResult.

    A subclass gives the grid and the state (:meth:`initial_state`), the compiled loop
    (:meth:`advance`) and the few reductions the trackers need."""

    name = ""
    #: a sloping seabed is the level grid with gravity turned (decision 0032)
    takes_slope = True
    config_model: type = CelConfig
    bodies: tuple[str, ...] = ()
    dim = 0  # axes of the grid, which pick the element kernels
    bytes_per_cell = BYTES_PER_CELL
    default_mesh = "standard"  # what mesh=auto runs (dsmv.config.scene.settle_mesh)

    @cached_property
    def kernels(self) -> DimensionKernels:
        """The element kernels and compiled loop of this solver's dimension (:func:`for_dimension`)."""
        return for_dimension(self.dim)

    @classmethod
    def check_scene(cls, scene: Scene) -> None:
        """What this solver cannot run, as a ConfigError at composition time: a body or contact it
        has not, or a run too long or too big for this machine (:meth:`check_cost`)."""
        cls.check_capabilities(scene)
        cls(scene, checked=True).check_cost()

    @classmethod
    def check_capabilities(cls, scene: Scene) -> ContactRules:
        """Refuse a body or contact this solver has not; return the scene's contact rules."""
        body = scene.geometry
        if body.kind not in cls.bodies:
            raise ConfigError("geometry.kind", body.kind, f"{cls.name} runs {', '.join(cls.bodies)} bodies")
        rules = ContactRules.of(scene, cls.is_axisymmetric(scene), True, cls.held_in(scene))
        refusal = rules.refusal()
        if refusal is not None:
            raise refusal
        landing = scene.landing
        if landing.attitude_key and not rules.turning:
            raise ConfigError(landing.attitude_key, getattr(landing, landing.attitude_key.split(".")[1]),
                              "a body touching down tilted is drawn turned into the grid: it needs the remap "
                              "(solver.remap=true)")
        if landing.kind == "drop":  # a landing's drift and turn at touchdown go on under the soil's reaction
            held = next((n for n in FREEDOM_NAMES if n != "z" and landing.given_velocity(n) and n not in landing.freedoms),
                        None)
            if held:
                raise ConfigError(f"landing.{RATE_KEYS[held]}", getattr(landing, RATE_KEYS[held]),
                                  f"a drop's drift or turn at touchdown moves on freely: add {held} to landing.free")
        return rules

    #: the freedoms a model of this solver has, by name (:data:`dsmv.cel.layout.FREEDOMS`)
    model_freedoms: tuple[str, ...] = FREEDOMS

    @classmethod
    def held_in(cls, scene: Scene) -> tuple[str, ...]:
        """The freedoms the symmetry planes of a scene's model hold (none without one)."""
        return ()

    def held_by_symmetry(self) -> tuple[str, ...]:
        """:meth:`held_in` this solver's scene."""
        return self.held_in(self.scene)

    def moving_freedoms(self) -> tuple[str, ...]:
        """The freedoms this model integrates under the soil's reaction: the landing's, those the model
        has, less those its symmetry planes hold."""
        held = self.held_by_symmetry()
        return tuple(n for n in self.scene.landing.freedoms if n in self.model_freedoms and n not in held)

    def rotational_inertia_kg_m2(self) -> tuple[float, float, float]:
        """The body's inertia about x, y and z through its centre of gravity, per track (kg·m²):
        ``landing.rotational_inertia_kg_m2``, else a uniform box B wide (a vehicle: across its tracks), L
        long and as high as a track's sprockets (else B): m·(L² + height²)/12, m·(B² + height²)/12,
        m·(B² + L²)/12."""
        landing = self.scene.landing
        if landing.rotational_inertia_kg_m2 is not None:
            return tuple(landing.rotational_inertia_kg_m2)
        return self.scene.geometry.box_inertia_kg_m2(self.start().inertia_kg)

    @staticmethod
    def is_axisymmetric(scene: Scene) -> bool:
        return False

    def __init__(self, scene: Scene, checked: bool = False):
        if not checked:
            self.check_capabilities(scene)
        self.scene = scene
        self.law = registry.load("soil_laws", scene.soil.law, "soil.law")(scene.soil)
        self.axisym = self.is_axisymmetric(scene)
        self.rules = ContactRules.of(scene, self.axisym, True, self.held_in(scene))
        self.cone = self.rules.kind == "cone"
        self.circular = self.rules.circular  # a cylinder (plane strain) or a ball (axisymmetric)
        self.longitudinal = self.rules.longitudinal

    # ------------------------------------------------------------------ sizing

    def hansbo_depth_m(self) -> float:
        """The cone's scale (m): Hansbo's penetration d = √(K·m·g/su) with K = 0.8 (30° cone), or,
        when deeper, the depth whose work ∫ su·z²/K dz = su·d³/(3K) takes up the touchdown energy
        ½·m·v² (without gravity Hansbo's depth is nil: the cells were nanometres, the run endless)."""
        landing, su = self.scene.landing, self.scene.soil.su0_pa
        static = math.sqrt(0.8 * landing.mass_kg * max(landing.gravity_m_s2, 1e-9) / su)
        return max(static, (1.5 * 0.8 * landing.mass_kg * landing.velocity_m_s**2 / su) ** (1 / 3))

    def cone_softening(self) -> float:
        """The cone's soil's rate-free softening (-), 1 when the law does not soften
        (:func:`dsmv.analytic.penetrometer.cone_softening`)."""
        if not getattr(self.law, "softens", False):
            return 1.0
        from dsmv.analytic.penetrometer import cone_softening

        return min(cone_softening(self.law), 1.0)

    def characteristic_width_m(self, travel: float) -> float:
        """The body's width for sizing the domain (m): B, or a cone's diameter at the expected depth."""
        body = self.scene.geometry
        if self.cone:
            return 2.0 * travel * math.tan(math.radians(0.5 * body.apex_angle_deg))
        return body.contact_length_m if self.longitudinal else body.width_m

    def half_span_m(self) -> float:
        """Half the body's width across x (m): B/2, or a vehicle's from its middle to its tracks' outer walls."""
        return self.scene.geometry.half_span_m

    def reach_m(self) -> float:
        """How far the body's farthest point in the x–z plane lies from its centre of gravity (m): the lever
        that turns an angle about y into a displacement at its edge (its walls counted up to one width)."""
        cg_x, cg_z = self.scene.landing.cg_offset_m[0], self.scene.landing.cg_offset_m[2]
        return math.hypot(self.half_span_m() + abs(cg_x), max(abs(cg_z), self.scene.geometry.width_m))

    def tracks_axis(self, h: float, beside_m: float, far_m: float) -> np.ndarray:
        """A vehicle's axis across its tracks (x ≥ 0): uniform cells h from its track's centre to
        ``beside_m`` beyond it, graded to ``far_m`` (:func:`~dsmv.cel.grid.axis_through`), so each
        track's walls sit on node lines wherever its centre falls."""
        offset, mesh = self.scene.geometry.track_offset_m, self.scene.mesh
        return axis_through(offset, offset + h * math.ceil(beside_m / h), far_m, h, mesh.growth_ratio,
                            mesh.max_cell_size_m)

    def contact_area_m2(self) -> float:
        """The area a bearing factor refers to: B·L in plane strain, π·B²/4 in axisymmetry (m²)."""
        B = self.scene.geometry.width_m
        return math.pi * B * B / 4 if self.axisym else B * self.scene.geometry.contact_length_m

    def expected_travel_m(self) -> float:
        """How far the body is expected to go (m): the push displacement, or the energy method's sinkage."""
        scene = self.scene
        if scene.solver.initial_travel_m:
            return scene.solver.initial_travel_m
        if scene.landing.kind == "push":
            return scene.landing.displacement_m
        if self.cone:  # a softening soil lets the cone 1/√s deeper (s: its rate-free softening, measured)
            return 1.5 * self.hansbo_depth_m() / math.sqrt(self.cone_softening())
        estimate = energy_estimate(scene)
        z = sinkage_in_profile(
            scene.landing.weight_per_track_n, scene.landing.inertia_per_track_kg, scene.landing.velocity_m_s,
            estimate.resistance_area_m2, scene.soil.strength,
        )
        return 1.5 * scene.geometry.width_m if math.isinf(z) else 1.5 * z + 0.05 * scene.geometry.width_m

    def core_cell_size(self, half: float) -> tuple[float, int]:
        """The core cell size h (m) and the cells across the body's half width: the body's edge falls
        on a node line; a cone's cells are sized to its expected penetration."""
        cfg = self.scene.solver
        if self.cone:
            h = min(self.scene.mesh.cell_size_m, self.hansbo_depth_m() / cfg.cone_cells_per_depth)
            return h, max(1, int(math.ceil(half / h)))
        n_half = max(1, int(round(half / self.scene.mesh.cell_size_m)))
        return half / n_half, n_half

    def trapped_soil_m(self) -> float:
        """The grouser height gh (m) when a track's grousers are modelled as the soil they trap
        (``geometry.grousers=trapped_soil``, where the track's side is modelled: the longitudinal view
        and 3D), else 0. The track is then its grousers' envelope, a flat base at their tips
        (:meth:`dsmv.cel.body.TrackSideView.of`), and its landing starts once the grousers have cut in
        (:meth:`start`). docs/decisions/0019 says why and what it was measured against."""
        body = self.scene.geometry
        if body.kind != "track" or body.grousers != "trapped_soil" or not self.base_at_grouser_tips:
            return 0.0
        return body.grouser_height_m

    def plates_above_base_m(self) -> float:
        """How far a track's plates lie above the body's base (m): the grouser height where the base is the
        grousers' tips, 0 in the study's cross-section (the base is the plates)."""
        return self.scene.geometry.grouser_height_m if self.base_at_grouser_tips else 0.0

    @property
    def base_at_grouser_tips(self) -> bool:
        """Whether a track's base is its grousers' tips: where its side is modelled, and in a cross-section
        asked for so (``geometry.section_base=grouser_tips``: the section of the track cel3d lands)."""
        return self.models_track_side or getattr(self.scene.geometry, "section_base", "plates") == "grouser_tips"

    @property
    def models_track_side(self) -> bool:
        """Whether a track's plates, grousers and sprockets are in the model (not its cross-section)."""
        return self.longitudinal

    def start(self) -> "Start":
        """The body at the start, per track: the landing's, or a track whose grousers trap soil once
        they have cut in: its base (the tips) gh below the mudline, the speed it gained falling gh
        under its wet weight (the thin blades' own resistance neglected), and the trapped soil's
        (buoyant) weight and mass carried with it."""
        landing, body, gh, soil = self.scene.landing, self.scene.geometry, self.trapped_soil_m(), self.scene.soil
        rho, height = weighed(soil.density_kg_m3, soil.density_layers, gh)  # a layered column weighs its own
        trapped_kg = rho * body.width_m * body.contact_length_m * height if gh > 0 else 0.0
        speed = landing.velocity_m_s
        if landing.kind == "drop" and gh > 0:
            speed = math.sqrt(speed**2 + 2.0 * landing.weight_per_track_n / landing.inertia_per_track_kg * gh)
        low = self.lowest_corner_m()
        return Start(landing.initial_depth_m + gh + low, speed, landing.inertia_per_track_kg + trapped_kg,
                     landing.weight_per_track_n + trapped_kg * landing.gravity_m_s2, gh + low)

    def mudline_m(self, h: float) -> float:
        """The mudline's height above the body's base (m): the landing's initial depth rounded to a node
        row of the uniform core (beyond it a cell the mudline cuts is partly filled), and a trapped-soil
        track's grouser height exactly, the same on every mesh; a body touching down tilted meets it with
        its lowest corner (:meth:`lowest_corner_m`)."""
        return h * round(self.scene.landing.initial_depth_m / h) + self.trapped_soil_m() + self.lowest_corner_m()

    def lowest_corner_m(self) -> float:
        """How high the lowest corner of the body's base lies above the upright base's plane at its attitude
        at first contact (``landing.pitch_deg``, ``roll_deg``, turned about its centre of gravity; m, 0 for a
        level touchdown), as the compiled loop measures it (:func:`~dsmv.cel.stepper.turned_base`)."""
        rise, lift = self.attitude_base_m()
        return rise - lift

    def attitude_base_m(self) -> tuple[float, float]:
        """How the body's attitude at first contact sets its base (m): the rise of its middle, and how far
        its lowest corner lies below the middle (:func:`~dsmv.cel.stepper.turned_base`); 0, 0 level."""
        landing = self.scene.landing
        if not landing.attitude_key:
            return 0.0, 0.0
        from dsmv.cel.stepper import turned_base

        return turned_base(*landing.attitude_rad[:2], *self.base_from_centre_of_gravity(), *self.base_half_spans())

    def base_from_centre_of_gravity(self) -> tuple[float, float, float]:
        """The middle of the base from the centre of gravity, x, y, z (m; a plane-strain model has no y)."""
        cg = self.scene.landing.cg_offset_m
        return -cg[0], -cg[1] if self.dim == 3 else 0.0, -cg[2]

    def base_half_spans(self) -> tuple[float, float]:
        """The base's half width across (x, a vehicle's to its tracks' outer walls) and half length along it
        (y; 0 in plane strain) (m): its corners, where a turned base is lowest."""
        return self.half_span_m(), 0.5 * (self.scene.geometry.contact_length_m or 0.0) if self.dim == 3 else 0.0

    # ------------------------------------------------------------------ run

    def trackers(self, state: State, run_dir) -> tuple[list, C.Zigzag]:
        """The observers and guards of a run, in the order they look."""
        scene, cfg, landing = self.scene, self.scene.solver, self.scene.landing
        drop = landing.kind == "drop"
        B = self.characteristic_width_m(self.travel)
        zigzag = C.Zigzag(lambda: self.hourglass_modes(state))
        trackers = [C.History(state.body.copy(), self.motion_columns(), self.held_by_symmetry()), zigzag]
        if self.rules.turning:  # after the chunk's history: a redraw moves soil and rejoins the ties
            from dsmv.cel.turn import Redraw

            trackers.append(Redraw(self, state, cfg.redraw_fraction))
        if scene.output.fields and run_dir is not None:
            trackers.append(C.Fields(self.field_recorder(state), lambda: self.snapshot(state), run_dir))
        v0 = state.body[B_VEL]
        speed_limit = 50.0 * (abs(v0) + landing.velocity_m_s + math.sqrt(max(landing.gravity_m_s2, 0.0) * B) + 1.0)
        if state.law is not None:  # a plugin's factor is checked before anything reads its strength
            trackers.append(C.LawOutput(lambda: state.cells.su, lambda cell: self.cell_state(state, cell),
                                        scene.soil.law))
        trackers += [
            C.NonFinite(lambda: self.state_arrays(state), cfg.cfl),
            C.EnergyRunaway(lambda: self.soil_kinetic_energy(state), state.kinetic_in, state.scale, cfg.cfl),
            C.SpeedLimit(lambda: self.largest_speed(state), speed_limit, cfg.cfl, cfg.hourglass),
            C.TopOfDomain(lambda: self.top_fill(state), self.travel, max(cfg.stress_cutoff, 1e-6)),
        ]
        if drop:
            # a body must slow down within one width of its own. A cone dropped from rest
            # accelerates for a while, and so does a body on a weak mudline over soil that
            # strengthens with depth (ks > 0: su0 = 500 Pa under the default track speeds up
            # over its first 0.6 m, then rests at 1.2 m); the soil can still stop them, so
            # they get the travel the domain was sized for
            width = scene.geometry.width_m
            if self.cone or scene.soil.ks_pa_per_m > 0:
                width = max(width, self.travel)
            turns = tuple(int(FORCE_SLOTS[FREEDOMS.index(n)]) for n in ("rx", "ry", "rz") if n in self.moving_freedoms())
            trackers += [C.Rest(state.par.body_weight == 0.0, cfg.economies.stop_at_rest, turns,
                                REST_OUT_OF_BALANCE * self.start().weight_n * self.reach_m(),
                                (1.0 - REST_OUT_OF_BALANCE) * state.par.body_weight * state.scale),
                         C.BearingFailure(width, width == scene.geometry.width_m), C.TravelLimit(self.travel)]
            if {"x", "y"} & set(self.moving_freedoms()):
                trackers.append(C.SlideFailure(scene.geometry.width_m))
        elif landing.cycles:
            trackers.append(C.Cycles(landing.displacement_m, landing.stroke_m, landing.cycles))
        else:
            driven = landing.driven
            trackers.append(C.PushEnd(landing.displacement_m, tuple(int(POSE_SLOTS[FREEDOMS.index(n)])
                                                                    for n in ("x", "y", "z") if n in driven),
                                      landing.rotation_deg if driven & {"rx", "ry", "rz"} else None))
        if not cfg.remap and landing.moves_beyond_vertical:
            trackers.append(C.MotionLimit(cfg.core_margin_widths * B, self.reach_m()))
        trackers.append(C.StepBudget(cfg.max_steps))
        if self.shows_progress():
            moving = set(self.moving_freedoms())
            trackers.append(C.Progress(self.expected_duration_s(), sys.stderr.isatty(), slides=bool(moving & {"x", "y"}),
                                       turns=bool(moving & {"rx", "ry", "rz"})))
        return trackers, zigzag

    def shows_progress(self) -> bool:
        """solver.progress: on, off, or auto — on outside sweeps (whose jobs would interleave)."""
        progress = self.scene.solver.progress
        return progress == "on" or (progress == "auto" and not in_sweep())

    def expected_duration_s(self, until_rest: bool = False) -> float:
        """How long the run is expected to last in simulated time (s): a push's displacement over its
        speed; a landing's time to rest from the fast landing model (milliseconds; within 10 % of the
        CEL on the default track in 2D and 3D), or the energy method's for bodies that model does not
        land; twice that when the run goes on past rest (``solver.economies.stop_at_rest=false``),
        unless ``until_rest``; for a body free to slide whose modelled landing slides on, the time it
        takes to slide one width (:meth:`slid_a_width_s`)."""
        landing, grav = self.scene.landing, self.scene.landing.gravity_m_s2
        if landing.kind == "drop" and self.cone:  # from rest under gravity; without it, at its touchdown speed
            return (4.0 * math.sqrt(2.0 * self.travel / grav) if grav > 0
                    else self.travel / max(landing.velocity_m_s, 0.1))
        if landing.kind == "push":
            return landing.push_duration_s
        if (slid := self.slid_a_width_s()) is not None:
            return slid
        rest = self.modelled_landing.metrics.get("time_to_rest_s", math.inf)
        if not math.isfinite(rest):  # the soil will not stop it: it runs through the travel near its speed
            return self.travel / max(landing.velocity_m_s, 0.1)
        return rest if until_rest or self.scene.solver.economies.stop_at_rest else 2.0 * rest

    @cached_property
    def modelled_landing(self) -> SolveResult:
        """The landing as a model that answers in milliseconds lands it, for the expected duration: the fast
        vehicle model for a vehicle that may turn (it rocks: its rest, 4× the fall's), the fast landing model
        for a track or strip, the energy method for other bodies."""
        scene = self.scene
        if (turning := self.turning_vehicle()) is not None:
            return fast_vehicle(turning).solve()
        if scene.geometry.kind in ("track", "strip"):
            return fast_landing(scene, "skempton" if self.dim == 3 and scene.geometry.kind == "track"
                                else "plane_strain").solve()
        return energy_estimate(scene).solve()

    def fast_model_slides_on(self) -> bool:
        """Whether the expected duration is the modelled landing's slide of one width (it does not rest)."""
        return self.slid_a_width_s() is not None

    def slid_a_width_s(self) -> Optional[float]:
        """When a modelled landing that slides on (the fast models end theirs after 20 B) has slid one width B,
        where the CEL's slide guard first may end a slide that does not slow
        (:class:`~dsmv.cel.controller.SlideFailure`); None for a body not free to slide, or a landing that
        rests or never slides that far. Only a drop free to slide is asked (a cone's duration is its fall's,
        and no model lands it). The 30 t vehicle on 45°, 17 % past its envelope: 0.89 s, where the fast
        model's 20 B took 4.80 s; cel3d on B/12 slid 0.54 m in 1.6 s, slowing, and on 48° was ended by the
        guard at 1.07 s."""
        if self.scene.landing.kind != "drop" or self.cone or not {"x", "y"} & set(self.moving_freedoms()):
            return None
        landed = self.modelled_landing
        history = landed.history
        if landed.status != "bearing_failure" or not history or "horizontal_displacement_m" not in history:
            return None
        slide = np.hypot(np.asarray(history["horizontal_displacement_m"], dtype=float),
                         np.asarray(history.get("lateral_displacement_m", 0.0), dtype=float))
        reached = np.flatnonzero(slide >= self.scene.geometry.width_m)
        return float(np.asarray(history["time_s"])[reached[0]]) if reached.size else None

    def turning_vehicle(self) -> Optional[Scene]:
        """A vehicle dropped free to pitch or roll: the scene as the fast vehicle model lands it (sinking,
        sliding and turning; a yaw left out), else None."""
        scene = self.scene
        if not (scene.geometry.vehicle and scene.landing.kind == "drop" and {"rx", "ry"} & set(self.moving_freedoms())):
            return None
        landing = scene.landing.model_copy(update={"free": [n for n in scene.landing.freedoms if n != "rz"],
                                                   "yaw_rate_rad_s": 0.0})
        return replace(scene, landing=landing)

    def steps_per_sample(self, state: State) -> int:
        """Steps per history sample, from the run's expected duration until rest (the same samples
        whether the run stops there or goes on)."""
        return max(1, int(self.expected_duration_s(until_rest=True) / state.par.dt / self.scene.solver.history_samples))

    def thread_count(self, cells: int) -> int:
        """Numba threads the kernels run on: the 2D kernels are serial."""
        return 1

    def cost(self) -> dict[str, float]:
        """What the run will take, estimated before any state is allocated: cells, soil cells (below
        the mudline), steps (the expected duration over the CFL step), memory (B), field output (B)
        and wall time (s, compile excluded; :mod:`dsmv.cel.cost`)."""
        from dsmv.cel.state import Elastic

        grid = self.build()
        counts = [len(a) - 1 for a in grid.axes]
        cells = float(np.prod(counts))
        up = grid.axes[-1]
        soil_cells = cells / counts[-1] * float(np.count_nonzero(0.5 * (up[1:] + up[:-1]) < self.mudline))
        soil = self.scene.soil
        dt = self.scene.solver.cfl * self.h / Elastic.of(soil, soil.lightest_density_kg_m3).wave_speed_m_s
        steps = min(self.expected_duration_s() / dt, self.scene.solver.max_steps)
        output = self.scene.output
        frames = 2 * output.field_frames + 2 if output.fields else 0
        return {"cells": cells, "soil_cells": soil_cells, "steps": steps,
                "memory_b": cells * (self.bytes_per_cell + frames * BYTES_PER_FRAME_CELL),
                "fields_b": cost_model.field_output_b(self.dim, cells, output.field_frames) if output.fields else 0.0,
                "wall_s": cost_model.measured().wall_s(self.dim, self.scene.soil.law, self.thread_count(int(cells)),
                                                 soil_cells, steps)}

    def check_cost(self) -> dict[str, float]:
        """Refuse, as a config error, a run estimated to outlast ``solver.max_wall_s`` or to outgrow the
        memory this machine has free."""
        cost = self.cost()
        what = f"{cost['cells']:,.0f} cells × {cost['steps']:,.0f} steps"
        if cost["memory_b"] > available_memory_b():
            raise ConfigError("mesh.cell_size_m", self.scene.mesh.cell_size_m,
                              f"{what} need about {cost['memory_b'] / 2**30:.1f} GiB, more than the "
                              f"{available_memory_b() / 2**30:.1f} GiB free: coarsen the mesh")
        limit = self.scene.solver.max_wall_s
        if cost["wall_s"] > limit:
            raise ConfigError("solver.max_wall_s", limit, f"{what} would take {cost_model.duration(cost['wall_s'])}; "
                              f"coarsen mesh.cell_size_m or raise solver.max_wall_s to run it")
        return cost

    def solve(self, run_dir=None) -> SolveResult:
        """Run the scene; with ``solver.error_estimate`` also on cells 2h and 4h, and add the answer's
        mesh error (:meth:`add_mesh_error`)."""
        result = self.solve_on_mesh(run_dir)
        if self.scene.solver.error_estimate and result.status == "ok":
            self.add_mesh_error(result)
        return result

    def core_cell_m(self) -> float:
        """The core cell size (m): the grid's once it is built, else the one the scene asks for."""
        return getattr(self, "h", self.scene.mesh.cell_size_m)

    def coarser(self, factor: int) -> "CelSolver":
        """This scene on cells ``factor`` times the core size (a cone: ``factor`` times fewer cells
        across its depth), without fields, progress or a further estimate."""
        scene = self.scene
        h = self.core_cell_m()
        cfg = scene.solver.model_copy(update={
            "error_estimate": False, "progress": "off",
            "cone_cells_per_depth": max(4, round(scene.solver.cone_cells_per_depth / factor))})
        return type(self)(replace(scene, mesh=scene.mesh.model_copy(update={"cell_size_m": factor * h}), solver=cfg,
                                  output=scene.output.model_copy(update={"fields": False})), checked=True)

    def coarsening_factors(self) -> tuple[int, ...]:
        """The coarser meshes the mesh error is measured on, in multiples of the core cell: 2h and 4h, but
        none wider than twice a trapped-soil track's grouser height. On wider cells the held wall is the
        base's half cell, not the grousers (:func:`dsmv.cel.contact.trapped_shares`), a jump that made three
        meshes B/16, B/8 and B/4 read order 2.8 and ± 0.0001 m where B/30 lay 0.0003 m off (decision 0042)."""
        gh, h = self.trapped_soil_m(), self.core_cell_m()
        return tuple(f for f in (2, 4) if gh == 0.0 or f * h <= 2.0 * gh * (1.0 + 1e-9))

    def add_mesh_error(self, result: SolveResult) -> None:
        """The answer on h with its discretisation error from runs on 2h and 4h (dsmv.convergence):
        ``<name>_extrapolated``, ``<name>_error`` and ``<name>_order`` for the max sinkage (names in
        metres: ``max_sinkage_extrapolated_m``, ``max_sinkage_error_m``) and each bearing factor."""
        from dsmv.convergence import first_order, richardson

        factors = self.coarsening_factors()
        if not factors:
            gh = self.trapped_soil_m()
            result.message += (f"; no mesh error: cells of 2h would be wider than twice the grousers' {gh:g} m, "
                               f"whose trapped soil they no longer measure (core cells of at most {gh:g} m give one)")
            return
        coarse = [self.coarser(factor) for factor in factors]
        if self.shows_progress():
            print(f"  mesh error: the scene on {' and '.join(f'{f}h' for f in factors)} too, "
                  f"{cost_model.duration(sum(c.cost()['wall_s'] for c in coarse))} more", file=sys.stderr)
        runs = [result] + [c.solve_on_mesh(None) for c in coarse]
        if any(r.status != "ok" for r in runs[1:]):
            result.message += (f"; no mesh error: the runs on {' and '.join(f'{f}h' for f in factors)} ended "
                               + ", ".join(r.status for r in runs[1:]))
            return
        if len(factors) == 1:
            result.message += ("; mesh error from h and 2h, first order assumed: cells of 4h would be wider than "
                               "twice the grouser height")
        estimator = richardson if len(factors) == 2 else first_order
        h = tuple(r.metrics["core_cell_size_m"] for r in runs)
        answers = ["max_sinkage_m", *NC_SAMPLES, "nc_deep"] if self.scene.landing.kind == "push" else ["max_sinkage_m"]
        for name in answers:
            if not all(name in r.metrics for r in runs):
                continue
            estimate = estimator(h, tuple(r.metrics[name] for r in runs))
            stem, unit = (name[:-2], "_m") if name.endswith("_m") else (name, "")
            result.metrics |= {f"{stem}_extrapolated{unit}": estimate.extrapolated, f"{stem}_error{unit}": estimate.error,
                               f"{stem}_order": estimate.order}
            result.units |= {f"{stem}_extrapolated{unit}": result.units[name], f"{stem}_error{unit}": result.units[name],
                             f"{stem}_order": "-"}

    def solve_on_mesh(self, run_dir=None) -> SolveResult:
        """One run on the scene's mesh."""
        cost = self.check_cost()
        if self.shows_progress():
            later = ""
            if self.fast_model_slides_on():  # the fast model's slide of a width, where the slide guard may end it
                later = (" (the fast model slides on: this counts the time it takes to slide one width, where a slide "
                         "that has not slowed ends; one that slows rests later)")
            elif self.turning_vehicle() is not None:  # cel3d's vehicle 0.3 m off rested at 0.64 s, the fast one at 0.16 s
                later = (" (at least: a vehicle rocks to rest later in the CEL than the fast vehicle model this "
                         "counts, 4 times at 0.3 m off)")
            elif self.scene.landing.kind == "drop" and set(self.moving_freedoms()) - {"z"}:
                # the 2D section rolling 0.5° with its centre of gravity 0.3 m off rested at 0.78 s, 18 × the fall
                later = (" (at least: a body free to slide or turn comes to rest later than the vertical landing "
                         "this counts)")
            print(f"  {cost['cells']:,.0f} cells, about {cost['steps']:,.0f} steps, {cost['memory_b'] / 2**20:,.0f} MiB, "
                  f"{cost_model.duration(cost['wall_s'])}{later}", file=sys.stderr)
        if cost["fields_b"] > cost_model.FIELD_NOTICE_B:
            print(f"  fields: about {cost['fields_b'] / 1e6:,.0f} MB on disk in up to "
                  f"{2 * self.scene.output.field_frames + 1} frames (output.field_frames="
                  f"{self.scene.output.field_frames})", file=sys.stderr)
        state = self.initial_state()
        trackers, zigzag = self.trackers(state, run_dir)
        run = C.Run(state, state.body, state.energy, force_scale=state.scale, start_sinkage_m=self.start().sinkage_m)
        controller = C.Controller(lambda n: self.advance(state, n), trackers, self.steps_per_sample(state),
                                  self.scene.solver.max_steps)
        ending, compile_s, wall_s = controller.run(run)
        rest = next((t.rest_time_s for t in trackers if isinstance(t, C.Rest)), None)
        result = self.result(state, run, ending, zigzag.ratio(), rest, compile_s, wall_s)
        if (redraws := next((t.redraws for t in trackers if hasattr(t, "redraws")), None)) is not None:
            result.metrics["redraws"], result.units["redraws"] = float(redraws), "-"
        result.metrics["estimated_wall_s"], result.units["estimated_wall_s"] = cost["wall_s"], "s"
        return result

    def result(self, state: State, run: C.Run, ending: C.Ending, zigzag: float, rest_time_s, compile_s,
               wall_s) -> SolveResult:
        """The run's metrics, units and history, and the checks an 'ok' run must pass."""
        cfg, soil, landing = self.scene.solver, self.scene.soil, self.scene.landing
        drop = landing.kind == "drop"
        body, par = state.body, state.par
        status, message = ending.status, ending.message
        mass_now = float(par.density * weighed_soil(state.cells, state.mesh, par).sum())
        mass_expected = state.mass0 + par.density * body[B_INFLOW]
        history = {k: np.asarray(v) for k, v in run.history.items()}
        cells = state.cells.phi.size
        metrics = {
            "mass_error": abs(mass_now - mass_expected) / state.mass0,
            "soil_entered_kg": par.density * body[B_INFLOW],  # net, through the base and the sides
            "phi_max": float(state.cells.phi.max()),
            "phi_min": float(state.cells.phi.min()),
            "compile_s": compile_s,
            "wall_s": wall_s,
            "steps": float(run.steps),
            "time_step_s": par.dt,
            "cells": float(cells),
            "cells_whole_body": float(self.whole_body_cells(cells)),
            "cell_updates_per_s": cells * max(run.steps - 1, 1) / max(wall_s, 1e-9),
            "core_cell_size_m": self.h,
            # the zig-zag in the velocity field: hourglass against linear modes, over the run
            # (a run gone unstable may have summed infinities: NaN, which its report leaves out)
            "hourglass_mode_ratio": zigzag,
        }
        units = {"mass_error": "-", "soil_entered_kg": "kg", "phi_max": "-", "phi_min": "-", "compile_s": "s",
                 "wall_s": "s", "steps": "-", "time_step_s": "s", "cells": "-", "cells_whole_body": "-",
                 "cell_updates_per_s": "1/s", "core_cell_size_m": "m",
                 "hourglass_mode_ratio": "-"}
        audit = ledger.audit(
            state.energy, kinetic_in=state.kinetic_in, kinetic_soil=self.soil_kinetic_energy(state),
            kinetic_body=self.body_kinetic_energy(state),
            elastic_change=self.elastic_energy(state) - state.elastic0, touchdown_loss=state.touchdown_loss,
            scale=state.scale)
        metrics |= audit
        units |= {k: ("-" if k == "energy_error" else "J") for k in audit}
        if status in ("ok", "out_of_domain", "bearing_failure"):
            metrics["max_sinkage_m"] = run.max_sinkage_m  # the body's base: a track's grousers' tips in 3D
            units["max_sinkage_m"] = "m"
        grav = landing.gravity_m_s2
        if drop and status == "ok" and self.cone and grav > 0:  # Hansbo's factor implied by the penetration
            metrics["hansbo_k"] = soil.su0_pa * metrics["max_sinkage_m"] ** 2 / (landing.mass_kg * grav)
            units["hansbo_k"] = "-"
        if drop and status == "ok":
            metrics["sinkage_over_width"] = metrics["max_sinkage_m"] / self.characteristic_width_m(self.travel)
            metrics["time_to_rest_s"] = float(body[B_TIME] if rest_time_s is None else rest_time_s)
            units |= {"sinkage_over_width": "-", "time_to_rest_s": "s"}
        if not drop:
            self._push_metrics(history, metrics, units)
        if landing.moves_beyond_vertical:
            self._motion_metrics(body, history, metrics, units)
        if status == "ok" and metrics["mass_error"] > 1e-6:
            status, message = "unstable", f"soil mass drifted by {metrics['mass_error']:.2e} (relative)"
        if status == "ok" and metrics["energy_error"] > ENERGY_ERROR_LIMIT:
            status, message = "unstable", (
                f"the energy audit is off by {metrics['energy_error']:.1%} (limit {ENERGY_ERROR_LIMIT:.0%}): "
                f"lower solver.cfl (now {cfg.cfl}) or raise solver.hourglass / solver.bulk_viscosity_linear")
        if status != "ok":  # a run that went wrong reports what stayed finite, never a NaN
            metrics = {k: v for k, v in metrics.items() if math.isfinite(v)}
            finite = np.all([np.isfinite(v) for v in history.values()], axis=0)
            history = {k: v[finite] for k, v in history.items()}
        result = SolveResult(status, message, metrics, units, history)
        if self.scene.geometry.kind == "track":
            add_plate_sinkage(result, self.plates_above_base_m())
        return result

    def _push_metrics(self, history, metrics, units) -> None:
        """Bearing factor q/su0 along a push: samples at fixed s/B and the curve's roughness."""
        scene = self.scene
        B = scene.geometry.width_m
        nc = history["force_n"] / (self.contact_area_m2() * scene.soil.su0_pa)
        s_over_b = history["sinkage_m"] / B
        # a cyclic push's strokes, 0 the first penetration, which the samples at fixed s/B read
        strokes = np.zeros(len(nc), dtype=np.int64)
        if scene.landing.cycles:
            strokes = np.cumsum(np.r_[0, np.diff((history["velocity_m_s"] > 0).astype(int)) != 0])
        for name, at in NC_SAMPLES.items():
            window = (np.abs(s_over_b - at) <= NC_WINDOW) & (strokes == 0)
            if window.any():
                metrics[name] = float(nc[window].mean())
                units[name] = "-"
        beyond = (s_over_b >= NC_SAMPLES["nc_at_0p02B"]) & (strokes == 0)
        if beyond.sum() > 2:
            metrics["nc_roughness"] = float(np.abs(np.diff(nc[beyond])).max())
            units["nc_roughness"] = "-"
        if self.circular:  # a T-bar (or ball): the deep factor is the mean over the last diameter pushed
            last = history["sinkage_m"] >= history["sinkage_m"][-1] - B
            landing = scene.landing
            if landing.cycles:  # the last penetration stroke's, and each cycle's over the middle half of its stroke
                last &= strokes == strokes[-1]
                middle = history["sinkage_m"][0] + landing.displacement_m - 0.5 * landing.stroke_m
                mid_stroke = np.abs(history["sinkage_m"] - middle) <= 0.25 * landing.stroke_m
                for cycle in range(1, landing.cycles + 2):
                    here = (strokes == 2 * (cycle - 1)) & mid_stroke
                    if here.any():
                        metrics[f"nc_cycle_{cycle}"] = float(nc[here].mean())
                        units[f"nc_cycle_{cycle}"] = "-"
            metrics["nc_deep"] = float(nc[last & (history["sinkage_m"] > 0)].mean())
            units["nc_deep"] = "-"
        metrics["max_force_n"] = float(history["force_n"].max())
        units["max_force_n"] = "N"

    def motion_columns(self) -> tuple[str, ...]:
        """The history columns of a body that may slide or turn (none for one that cannot): those of the
        freedoms this model has (:data:`dsmv.cel.controller.MOTION_COLUMNS`)."""
        if not self.scene.landing.moves_beyond_vertical:
            return ()
        return tuple(name for name, (_, q) in C.MOTION_COLUMNS.items() if FREEDOMS[q] in self.model_freedoms)

    def _motion_metrics(self, body, history, metrics, units) -> None:
        """A body that may slide or turn: its largest rotation and displacement in plan, the deepest sinkage
        of its base's lowest point (``max_edge_sinkage_m``; ``max_sinkage_m`` is the middle's), where it ended
        (each column's last value), the largest force and moment on it, and the loads at the end (the
        mean over the last twentieth of the history: a probe's limit load), for a push also as factors
        V/(A·su0), H/(A·su0) and M/(A·B·su0) of the resistance (against +x and +ry)."""
        end = slice(-max(1, len(history["time_s"]) // 20), None)
        metrics |= {"max_rotation_deg": math.degrees(body[B_MAXROT]), "max_horizontal_displacement_m": body[B_MAXSLIDE],
                    "max_edge_sinkage_m": self.start().sinkage_m + float(body[B_MAXEDGE]),
                    "end_force_n": float(history["force_n"][end].mean())}
        units |= {"max_rotation_deg": "deg", "max_horizontal_displacement_m": "m", "max_edge_sinkage_m": "m",
                  "end_force_n": "N"}
        if self.scene.landing.kind == "push":  # the probe's end load as bearing factors, resistance +
            area, su0 = self.contact_area_m2(), self.scene.soil.su0_pa
            metrics |= {"end_vertical_factor": metrics["end_force_n"] / (area * su0),
                        "end_horizontal_factor": -float(history["horizontal_force_n"][end].mean()) / (area * su0),
                        "end_moment_factor": -float(history["moment_n_m"][end].mean())
                        / (area * self.scene.geometry.width_m * su0)}
            units |= {"end_vertical_factor": "-", "end_horizontal_factor": "-", "end_moment_factor": "-"}
        if self.scene.landing.attitude_key:  # how far its tilt drops the base across, end to end
            metrics["attitude_drop_m"], units["attitude_drop_m"] = 2.0 * self.attitude_base_m()[1], "m"
        if self.scene.geometry.vehicle:
            add_vehicle_answers(metrics, units, history, self.scene.geometry, self.plates_above_base_m())
        for name in self.motion_columns():
            unit = {"_n": "N", "_m": "N·m" if name.endswith("_n_m") else "m", "eg": "deg"}[name[-2:]]
            if C.MOTION_COLUMNS[name][0] == "reaction":
                metrics[f"max_{name}"] = float(np.abs(history[name]).max())
                metrics[f"end_{name}"] = float(history[name][end].mean())
                units[f"max_{name}"] = units[f"end_{name}"] = unit
            else:
                metrics[name], units[name] = float(history[name][-1]), unit

    def body_kinetic_energy(self, state: State) -> float:
        """The body's own kinetic energy in its free freedoms (J per unit thickness or per radian): a pushed
        freedom's is the push's business."""
        par, body = state.par, state.body
        energy = 0.0
        for q, name in enumerate(FREEDOMS):
            if (par.free >> q) & 1:
                inertia = par.body_mass if q < 3 else (par.inertia_x, par.inertia_y, par.inertia_z)[q - 3]
                energy += 0.5 * inertia * body[VELOCITY_SLOTS[q]] ** 2
        return energy

    # ------------------------------------------------------------------ the compiled loop

    def law_kernel(self, par: Params, n_state: int) -> Optional[SoilLawKernel]:
        """The soil law as the kernels call it, or None when it neither changes the strength (or is not
        evaluated) nor carries state: the loop then compiles without the calls."""
        if not (par.law_active or n_state):
            return None
        return SoilLawKernel.of(self.law)

    def touchdown(self, state: State) -> None:
        """The body starts at the velocities it was given (a drop's fall, drift and turn, a push's speeds);
        a drop and the soil nodes it meets become one rigid unit, their momentum and moment of momentum
        kept in every free freedom (:func:`~dsmv.cel.stepper.rejoin_ties`; the kinetic energy lost is the
        touchdown's, and a centre of gravity off the contact's middle starts the body turning); the
        tied nodes start with the body's velocity."""
        from dsmv.cel.kernels.nodes import apply_ties
        from dsmv.cel.stepper import body_inertia, rejoin_ties

        par, body, landing = state.par, state.body, self.scene.landing
        speed = self.start().velocity_m_s
        for q, name in enumerate(FREEDOMS):
            body[VELOCITY_SLOTS[q]] = -speed if name == "z" else landing.given_velocity(name)
        if landing.attitude_key:  # its attitude at first contact, and where that leaves its base
            body[B_ROT_X:B_ROT_Z + 1] = landing.attitude_rad
            body[B_MAXROT] = math.sqrt(sum(a * a for a in landing.attitude_rad))
            rise, lift = self.attitude_base_m()
            body[B_SINKAGE] = body[B_MAXDISP] = -rise
            body[B_MAXEDGE] = lift - rise
        if not par.drop:
            apply_ties(state.contact, state.nodes, body)
            return
        state.kinetic_in = sum(0.5 * body_inertia(par, q) * body[VELOCITY_SLOTS[q]] ** 2 for q in range(6))
        change = np.zeros(2)
        rejoin_ties(state.contact, state.nodes, par, body, change)
        state.touchdown_loss = -change[0]

    def hourglass_modes(self, state: State) -> tuple[float, float]:
        return self.kernels.hourglass_modes(state.mesh.corner, state.cells.phi, state.nodes.v, ZIGZAG_FULL_CELL)

    def elastic_energy(self, state: State) -> float:
        cells, par = state.cells, state.par
        return self.kernels.elastic_energy(cells.phi, cells.q, state.mesh.vol, par.shear, par.bulk)

    @staticmethod
    def loop_arguments(state: State) -> tuple:
        """What the compiled loop takes after the step count."""
        return (state.mesh, state.cells, state.faces, state.nodes, state.contact, state.inflow, state.par, state.body,
                state.energy, state.law)

    def advance(self, state: State, n: int) -> tuple[int, int]:
        """``n`` steps of the compiled loop (its machine code found once, then called directly)."""
        args = self.loop_arguments(state)
        if state.stepper is None:
            from dsmv.cel.kernels.common import compiled_entry

            state.stepper = compiled_entry(self.kernels.run_steps, (n, *args))
        return state.stepper(n, *args)

    def remap_now(self, state: State) -> None:
        """The Eulerian phase now, whatever the soil's travel since the last (a redraw needs the soil on
        the grid)."""
        swept = np.zeros((len(state.contact.split_node), 2))
        self.kernels.remap(state.mesh, state.cells, state.faces, state.nodes, state.contact, state.inflow, state.par,
                           state.body, state.energy, swept)

    def field_recorder(self, state: State):
        from dsmv.cel.fields import FieldRecorder

        recorder = FieldRecorder(state.grid, state.cells.solid, state.mesh.corner, tresca=state.par.tresca,
                                 stress_cutoff=self.scene.solver.stress_cutoff,
                                 frames=self.scene.output.field_frames,
                                 spacing_s=self.steps_per_sample(state) * state.par.dt,
                                 density=(state.par.density, state.par.density_row))
        recorder.sample(0.0, 0.0, *self.snapshot(state))
        return recorder

    def snapshot(self, state: State) -> tuple:
        """What a field frame copies: φ, the cell state, the kernels' strength and shear strain rate,
        and the velocities of all nodes."""
        rate = self.kernels.shear_strain_rates(state.mesh, state.cells, state.faces, state.nodes, state.par,
                                               state.body[B_VEL])
        return state.cells.phi, state.cells.q, state.cells.su, rate, state.nodes.v

    def cell_state(self, state: State, cell: tuple) -> str:
        """One cell's state in words, as the soil law saw it: ξ, γ̇ and the law's state variables."""
        rows = CellRows(self.dim)
        _, _, _, rate, _ = self.snapshot(state)
        q = state.cells.q
        words = [f"ξ = {q[(rows.xi, *cell)]:.4g}", f"γ̇ = {rate[cell]:.4g} 1/s"]
        words += [f"{name} = {q[(rows.base + k, *cell)]:.4g}" for k, name in enumerate(self.law.state_variables())]
        return f"cell {cell} (" + ", ".join(words) + ")"

    # ------------------------------------------------------------------ state reductions

    @staticmethod
    def top_fill(state: State) -> float:
        """The fullest cell of the grid's top layer (-)."""
        return float(state.cells.phi[..., -1].max())

    @staticmethod
    def soil_kinetic_energy(state: State) -> float:
        """The soil's kinetic energy on all nodes, split ones included (J per unit thickness or per radian)."""
        from dsmv.cel.kernels.nodes import kinetic_energy

        return kinetic_energy(state.nodes.mass, state.nodes.v)

    @staticmethod
    def largest_speed(state: State) -> float:
        from dsmv.cel.kernels.nodes import largest_speed

        return largest_speed(state.nodes.v)

    @staticmethod
    def state_arrays(state: State) -> list:
        """What must stay finite: the vertical velocities and the cell state."""
        return [state.nodes.v[-1], state.cells.q]

    # ------------------------------------------------------------------ state

    def initial_state(self) -> State:
        """Grid, body and contact, the geostatic soil, the step's parameters, and the touchdown; a
        subclass gives the grid (:meth:`build`), the body's contact (:meth:`body_contact`), the mesh and
        faces (:meth:`mesh_and_faces`) and whether the soil may part from the body
        (:meth:`contact_separation`)."""
        from dsmv.cel.kernels.nodes import nodal_mass_of_soil

        scene, cfg = self.scene, self.scene.solver
        soil, landing = scene.soil, scene.landing
        grid = self.build()
        shape = tuple(len(a) - 1 for a in grid.axes)
        # gravity in the grid's frame, which lies along the seabed: down its normal and along it
        gravity_x, gravity_y, grav = soil.gravity_components(landing.gravity_m_s2)
        # a layered soil carries its cells' densities over the lightest layer's, whose waves are the fastest
        layers, rho = soil.density_layers, soil.lightest_density_kg_m3
        elastic = Elastic.of(soil, rho)
        body_contact = self.body_contact(grid)
        if self.scene.landing.attitude_key:  # drawn at its attitude (after the upright drawing's footprint)
            body_contact = self.body_contact(grid, np.array(self.scene.landing.attitude_rad))
        body_contact = replace(body_contact, contact=self.seated(body_contact.contact))
        open_frac = body_contact.openings.open_frac
        phi, q = geostatic_state(grid, rho, grav, elastic.k0, self.mudline, open_frac, (gravity_x, gravity_y), layers)
        # the soil law's state variables ride with the material, as ξ and z0 do, and a layered soil's density last
        law_state = self.law.initial_state()
        n_base = q.shape[0]
        q = np.concatenate([q, np.broadcast_to(law_state.reshape(-1, *(1,) * self.dim), (len(law_state), *shape)),
                            *([density_ratios(grid, self.mudline, layers, phi)[None]] if layers is not None else [])])
        mesh, faces = self.mesh_and_faces(grid, body_contact)
        shared = np.full(shape, np.nan)  # a merged sliver pair's shared divergence, NaN elsewhere
        merge = body_contact.contact.merge
        shared[tuple(merge[:, :self.dim].T)] = 0.0
        shared[tuple(merge[:, self.dim:].T)] = 0.0
        cells = Cells(phi, q, np.zeros(shape), body_contact.strength_factor, body_contact.solid, open_frac,
                      body_contact.gap, shared, hourglass_factor(open_frac, cfg.hourglass_cells(scene.geometry.kind)))
        n_nodes = body_contact.n_nodes
        nodes = Nodes(*(np.zeros((self.dim, n_nodes)) for _ in range(2)), np.zeros(n_nodes),
                      np.zeros((self.dim, n_nodes)))
        scale, start = self.model_scale(), self.start()
        drop = landing.kind == "drop"
        par = step_parameters(
            dt=cfg.cfl * self.h / elastic.wave_speed_m_s, density=rho, elastic=elastic, h=self.h, gravity=grav,
            su0=soil.su0_pa, ks=soil.ks_pa_per_m, strength=soil.strength, hourglass=cfg.hourglass, bulk_linear=cfg.bulk_viscosity_linear,
            bulk_quadratic=cfg.bulk_viscosity_quadratic, stress_cutoff=cfg.stress_cutoff,
            body_mass=start.inertia_kg / scale,
            # the body's weight along the grid's axes: down the seabed's normal and, on a slope, along it
            **{name: start.weight_n / scale * g / max(landing.gravity_m_s2, 1e-300)
               for name, g in (("body_weight", grav), ("weight_x", gravity_x), ("weight_y", gravity_y))},
            sloped=gravity_x != 0.0 or gravity_y != 0.0, gravity_x=gravity_x, gravity_y=gravity_y,
            push_velocity=landing.velocity_m_s, remap_courant=cfg.remap_courant,
            axisymmetric=self.axisym, advection_order=cfg.advection_order, drop=drop, inflow=True, remap=cfg.remap,
            law_active=self.law.any_layer_active or not cfg.economies.skip_inactive_law, skip_void=cfg.economies.skip_void,
            separation=self.contact_separation(), free=freedom_mask(self.moving_freedoms()),
            **{f"inertia_{axis}": inertia / scale for axis, inertia in zip("xyz", self.rotational_inertia_kg_m2())},
            **dict(zip(("base_x", "base_y", "base_z"), self.base_from_centre_of_gravity())),
            # a drifting drop is at rest once it also slides slower than 1 % of its speed at touchdown
            rest_speed=REST_SPEED_AFTER_FALL * max(start.velocity_m_s, math.hypot(landing.horizontal_velocity_m_s,
                                                                landing.lateral_velocity_m_s)),
            **dict(zip(("base_half_x", "base_half_y"), self.base_half_spans())),
            tresca=cfg.yield_surface == "tresca" or (cfg.yield_surface == "auto" and self.axisym),
            density_layers=layers, density_row=q.shape[0] - 1 if layers is not None else -1,
        )
        nodal_mass_of_soil(mesh, cells, par, nodes.mass)
        up = grid.axes[-1]
        ghost = np.zeros((q.shape[0], *shape[:-1]))
        ghost[n_base:n_base + len(law_state)] = law_state.reshape(-1, *(1,) * (self.dim - 1))  # soil entering
        side = np.zeros((q.shape[0], shape[-1]))  # at the base brings it, and soil entering at the sides
        side[n_base:n_base + len(law_state)] = law_state[:, None]
        inflow = Inflow(ghost, np.full(shape[:-1], self.mudline - (up[0] - 0.5 * (up[1] - up[0]))), side,
                        np.zeros(shape[-1]), np.asarray(up, dtype=float), float(self.mudline))
        state = State(grid, mesh, cells, faces, nodes, body_contact.contact, inflow, par, np.zeros(N_BODY),
                      np.zeros(ledger.N_ENERGY), self.law_kernel(par, len(law_state)), scale,
                      float(rho * weighed_soil(cells, mesh, par).sum()),
                      self.kernels.elastic_energy(phi, q, mesh.vol, par.shear, par.bulk),
                      0.0, 0.5 * par.body_mass * start.velocity_m_s**2 if drop else 0.0)
        self.touchdown(state)
        return state

    def seated(self, contact):
        """The contact as this scene seats the body: its ties' levers from the centre of gravity
        (``landing.cg_offset_m`` from the middle of the base: x, y, z; a plane-strain model has x and z),
        and on a sloping seabed the grid's far sides held in every direction (the infinite slope beyond
        carries the shear on them that rollers would not)."""
        offset = np.asarray(self.scene.landing.cg_offset_m, dtype=float)
        offset = offset[[0, 2]] if self.dim == 2 else offset
        contact = contact._replace(arm=np.ascontiguousarray(contact.arm - offset))
        if self.scene.soil.slope_deg == 0:
            return contact
        node_shape = tuple(len(a) for a in self.grid.axes)
        index = np.arange(int(np.prod(node_shape))).reshape(node_shape)
        nodes, axes = [contact.fixed_node], [contact.fixed_axis]
        for side_axis in range(self.dim - 1):
            ends = self.far_sides(side_axis)
            if not ends:
                continue
            side = np.concatenate([np.take(index, [end], axis=side_axis).ravel() for end in ends])
            for a in range(self.dim):
                if a != side_axis:  # the rollers hold the normal one already
                    nodes.append(side), axes.append(np.full(side.size, a))
        return contact._replace(fixed_node=np.concatenate(nodes).astype(np.int64),
                                fixed_axis=np.concatenate(axes).astype(np.int64))

    def far_sides(self, axis: int) -> tuple[int, ...]:
        """The ends (0, −1) of a horizontal axis that are the grid's far sides, not a symmetry plane of the
        model (which holds only the motion across it)."""
        return (0, -1)

    def contact_separation(self) -> bool:
        """Whether the body's faces let go of soil that pulls away (the contact rules' word)."""
        return self.rules.separation
