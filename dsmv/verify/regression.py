"""The regression scenes: every metric of a fixed set of scenes, written and compared across commits.

``dsmv-bench --regression FILE`` runs each scene of :data:`SCENES` in this process (tracking off,
no plots) and writes its status, message and every metric but the timings to ``FILE`` (JSON);
``--against REF`` then prints, scene by scene, the largest relative difference from ``REF`` and
the scene's headline value on both sides. A change that should leave the numerics alone is
checked this way: run it on the commit before (``git worktree`` + ``PYTHONPATH``) and after.

The scenes are the verification cases (the Prandtl strip at B/10, B/20, B/40, rough and smooth,
bonded, small strain and the whole section; limited adhesion; the T-bar at D/20; the circular
plate; the fall cone), the default landing and its variants, the stress suite's scenes
(:data:`STRESS_SCENES`, which tests/test_stress.py checks for physics) and the two checks
without a body.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from dsmv import registry
from dsmv.verify import canonical

#: the stress suite's scenes: extreme but legal (tests/test_stress.py holds each to its physics)
STRESS_SCENES = {
    "su0_500_pa": ("soil.su0_pa=500",),
    "touchdown_10_m_s_10500_kg": ("landing.velocity_m_s=10", "landing.mass_kg=10500"),
    "st_10_xi95_10": ("soil.law=einav_randolph", "soil.sensitivity=10", "soil.xi95=10"),
    "eta_0p15_at_10_m_s": ("soil.law=einav_randolph", "soil.rate.eta=0.15", "landing.velocity_m_s=10"),
    "ks_0_too_heavy": ("soil.su0_pa=2000", "soil.ks_pa_per_m=0", "landing.mass_kg=10500"),
    "cfl_1_beyond_limit": ("solver.cfl=1.0",),
    "cfl_0p7_near_limit": ("solver.cfl=0.7",),
    "domain_too_short": ("solver.initial_travel_m=0.03",),
    "rigid_boundaries_1_B_away": ("solver.domain_depth_widths=1", "solver.domain_half_width_widths=1"),
    "zero_gravity": ("landing.gravity_m_s2=0",),
    "zero_gravity_cone_thrown_at_1_m_s": ("geometry=fall_cone_30deg", "landing.velocity_m_s=1", "landing.gravity_m_s2=0"),
}

def stress_scene(overrides) -> list[str]:
    """A stress-suite scene: the default landing, on Tresca soil unless the scene names its law and on
    the medium mesh (0.04 m) unless it names one: the suite's figures were measured so."""
    def named(prefix):
        return any(o.startswith(prefix) for o in overrides)

    law = [] if named("soil.law=") else ["soil.law=tresca"]
    mesh = [] if named("mesh=") or named("mesh.cell_size_m=") else ["mesh=medium"]
    return ["solver=cel2d", *law, *mesh, *overrides]


_PRANDTL = [*canonical.PRANDTL, "landing.displacement_m=0.065"]
_BONDED = [*canonical.PRANDTL_BONDED, "landing.displacement_m=0.065", "mesh.cell_size_m=0.05"]
_TBAR = [*canonical.TBAR, "landing.displacement_m=0.1"]
#: a 3D plate pushed 0.05 B in small strain into weightless Tresca soil (tests/test_cel3d.py's push)
_SMALL_STRAIN_3D = ["solver=cel3d", "landing=push", "soil.law=tresca", "soil.su0_pa=10000", "soil.ks_pa_per_m=0",
                    "soil.youngs_modulus_pa=5e6", "landing.gravity_m_s2=0", "landing.velocity_m_s=0.1",
                    "landing.displacement_m=0.05", "solver.contact_separation=false", "solver.remap=false"]


def _scenes() -> dict[str, list[str]]:
    scenes = {}
    for h, name in ((0.1, "B10"), (0.05, "B20"), (0.025, "B40")):
        for roughness in ("rough", "smooth"):
            scenes[f"prandtl_{roughness}_{name}"] = [*_PRANDTL, f"mesh.cell_size_m={h}", f"geometry.roughness={roughness}"]
    scenes |= {
        "prandtl_rough_B20_bonded": _BONDED,
        "prandtl_smooth_B20_bonded": [*_BONDED, "geometry.roughness=smooth"],
        "prandtl_rough_B20_small_strain": [*_BONDED, "solver.remap=false"],
        "prandtl_rough_B20_whole_section": [*_BONDED, "solver.economies.symmetry=false"],
        "adhesion_0.5_B20": [*_BONDED, "landing.displacement_m=0.06", "geometry.roughness=0.5"],
        "adhesion_0.2_B20": [*_BONDED, "landing.displacement_m=0.06", "geometry.roughness=0.2"],
        "adhesion_0.5_B20_separation": [*_PRANDTL, "mesh.cell_size_m=0.05", "geometry.roughness=0.5"],
        "tbar_rough_D20": [*_TBAR, "geometry.roughness=rough"],
        "tbar_smooth_D20": [*_TBAR, "geometry.roughness=smooth"],
        "tbar_0.5_D20": [*_TBAR, "geometry.roughness=0.5"],
        "circular_plate_rough_B20": [*_BONDED, "landing.displacement_m=0.11", "solver.mode=axisymmetric",
                                     "solver.remap=false"],
        "circular_plate_rough_B20_remap": [*_BONDED, "landing.displacement_m=0.11", "solver.mode=axisymmetric"],
        "fall_cone": ["solver=cel2d", "geometry=fall_cone_30deg", "soil.law=tresca"],
        "default_landing": list(canonical.LANDING),
        "default_landing_coarse": ["solver=cel2d", "mesh=coarse"],
        "landing_medium": ["solver=cel2d", "mesh=medium"],
        # the former default landing: Tresca, the soil tied to the track, medium mesh (0.12586 m)
        "landing_tresca_bonded_medium": ["solver=cel2d", "soil.law=tresca", "solver.contact_separation=false",
                                         "mesh=medium"],
        "landing_tresca_medium": ["solver=cel2d", "soil.law=tresca", "mesh=medium"],
        "landing_einav_randolph_bonded_medium": ["solver=cel2d", "solver.contact_separation=false", "mesh=medium"],
        "landing_smooth_medium": ["solver=cel2d", "soil.law=tresca", "solver.contact_separation=false",
                                  "geometry.roughness=smooth", "mesh=medium"],
        "landing_longitudinal": ["solver=cel2d", "geometry.view=longitudinal", "mesh=coarse"],
        "track_3d_landing": ["solver=cel3d", "mesh.cell_size_m=0.15"],
        "track_3d_landing_tresca": ["solver=cel3d", "mesh.cell_size_m=0.15", "soil.law=tresca"],
        "square_plate_3d_rough_B10": [*_SMALL_STRAIN_3D, "geometry=rectangular_plate",
                                      "mesh.cell_size_m=0.1"],
        "circular_plate_3d_rough_B10_remap": [*_SMALL_STRAIN_3D[:-1], "geometry=circular_plate", "mesh.cell_size_m=0.1"],
        "geostatic": ["experiment=verify_geostatic", "hydra.mode=RUN"],
        "advection": ["experiment=verify_advection", "hydra.mode=RUN"],
    }
    scenes |= {f"stress_{name}": stress_scene(overrides) for name, overrides in STRESS_SCENES.items()}
    checks = ("geostatic", "advection")  # cel2d_check has no progress setting
    return {name: o if name in checks else [*o, "solver.progress=off"] for name, o in scenes.items()}


SCENES = _scenes()
#: what a regression run leaves out: metrics of the machine, not of the result
TIMINGS = {"compile_s", "wall_s", "cell_updates_per_s", "estimated_wall_s"}
#: metrics at round-off level (their size is noise): compared absolutely
ROUNDOFF = {"mass_error", "phi_min", "max_speed_m_s", "energy_error"}
QUIET = ["tracking=disabled", "output.plots=false"]


def run_scene(overrides: list[str]) -> dict:
    """One scene in this process: status, message and every metric but the timings."""
    from dsmv.config.tree import compose_scene

    scene = compose_scene([*overrides, *QUIET])
    result = registry.load("solvers", scene.solver.name, "solver.name")(scene).solve()
    return {"status": result.status, "message": result.message,
            "metrics": {k: v for k, v in result.metrics.items() if k not in TIMINGS}}


def write(path: Path, only: list[str] | None = None) -> dict:
    """Run the scenes (all, or those named) and write their metrics to ``path``; scenes already in the
    file are kept, so an interrupted run resumes."""
    done = json.loads(path.read_text()) if path.exists() else {}
    for name, overrides in SCENES.items():
        if (only and name not in only) or name in done:
            continue
        done[name] = run_scene(overrides)
        print(f"  {name}: {done[name]['status']}", flush=True)
        path.write_text(json.dumps(done, indent=1, sort_keys=True))
    return done


def headline(metrics: dict) -> str | None:
    for name in ("nc_deep", "nc_at_0p05B", "hansbo_k", "max_sinkage_m"):
        if name in metrics:
            return name
    return next(iter(metrics), None)


def difference(x: float, y: float, name: str, energy_scale: float) -> float:
    """How far two values of a metric are apart: absolute for round-off metrics, relative to the
    energy delivered for energy terms, relative otherwise."""
    if x == y:
        return 0.0
    if name in ROUNDOFF:
        return abs(x - y)
    if name.startswith("energy_"):
        return abs(x - y) / max(abs(x), energy_scale, 1e-300)
    return abs(x - y) / max(abs(x), 1e-300)


def compare(reference: dict, results: dict) -> list[str]:
    """One line per scene: the largest difference, which metric, and the headline value on both sides."""
    lines = []
    for name, ref in reference.items():
        if name not in results:
            continue
        new = results[name]
        if ref["status"] != new["status"]:
            lines.append(f"{name}: status {ref['status']} -> {new['status']}")
            continue
        a, b = ref["metrics"], new["metrics"]
        scale = max((abs(a.get(k, 0.0)) for k in a if k.startswith("energy_in_")), default=0.0)
        diffs = {k: difference(a[k], b[k], k, scale) if k in b else math.inf for k in a if k not in TIMINGS}
        worst = max(diffs, key=diffs.get, default=None)
        key = headline(a)
        lines.append(f"{name}: {new['status']}, largest difference {diffs.get(worst, 0.0):.1e} ({worst}); "
                     f"{key} {a.get(key)!r} -> {b.get(key)!r}")
    return lines
