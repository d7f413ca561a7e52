"""Limited adhesion at the contact (geometry.roughness = α in (0, 1)): the face pulls the soil
along by at most α·su, on flat-faced bodies (strip, track cross-section).

Truths: Prandtl's 2 + π does not depend on the roughness of the base (Prandtl's mechanism for a
rough base, Hill's for a smooth one, the same limit load), so every α must give the same small-
strain load; on an embedded strip the walls add a shear of at most α·su, so the load rises with
α from smooth to rough; and the energy audit closes with the slip dissipation counted on its own.
"""

from __future__ import annotations

import pytest

from dsmv.cel.solver2d import Cel2DSolver
from dsmv.config.scene import build_scene
from dsmv.errors import ConfigError
from dsmv.verify import canonical

#: Prandtl's strip with the soil tied to its walls (dsmv.verify.canonical), small strain on B/10 cells
STRIP = [*canonical.PRANDTL_BONDED, "solver.progress=off", "solver.remap=false", "solver.initial_travel_m=0.1",
         "mesh.cell_size_m=0.1"]


@pytest.fixture
def push(compose_cfg):
    def _run(roughness, *overrides):
        result = Cel2DSolver(build_scene(compose_cfg([*STRIP, f"geometry.roughness={roughness}", *overrides]))).solve()
        assert result.status == "ok", result.message
        return result.metrics

    return _run


def test_base_adhesion_leaves_prandtl_unchanged(push):
    loads = {r: push(r, "landing.displacement_m=0.06")["nc_at_0p05B"] for r in ("rough", 0.5, 0.2, "smooth")}
    for r, nc in loads.items():  # B/10: +6.3 % over 2 + π for every roughness (mesh error, not roughness)
        assert nc == pytest.approx(loads["rough"], rel=2e-3), loads


def test_wall_adhesion_raises_the_load_with_alpha_and_the_audit_counts_the_slip(push):
    """A strip wished in place 1 B deep: its walls slide past the soil. The load grows with α,
    the slip dissipation is a term of its own (dropping it breaks the 2 % audit)."""
    runs = {r: push(r, "landing.initial_depth_m=1.0", "landing.displacement_m=0.06") for r in ("smooth", 0.25, 0.5, "rough")}
    loads = [m["nc_at_0p05B"] for m in runs.values()]
    assert all(a < b for a, b in zip(loads, loads[1:])), loads
    assert loads[-1] - loads[0] > 1.5, loads  # walls 1 B high on each side: up to +2·su·D/(su·B) = +2
    m = runs[0.5]
    assert m["energy_error"] < 1e-3
    assert runs["smooth"]["energy_contact_slip_j"] == 0.0 < runs["rough"]["energy_contact_slip_j"]  # rough: α = 1
    delivered = m["energy_in_push_j"]
    assert m["energy_contact_slip_j"] > 0.02 * delivered
    inputs = sum(v for k, v in m.items() if k.startswith("energy_in_"))
    outputs = sum(v for k, v in m.items() if k.startswith("energy_") and not k.startswith("energy_in_")
                  and k not in ("energy_error", "energy_contact_slip_j"))
    assert abs(inputs - outputs) / delivered > 0.02


def test_a_landing_sinks_deeper_the_less_the_track_adheres(compose_cfg):
    # 0.04 m cells: on 0.08 m cells the walls' share (0.2 % of the sinkage) is below the mesh's resolution
    base = ["solver=cel2d", "mesh=medium", "solver.progress=off", "soil.su0_pa=3000"]
    sinkage = []
    for r in ("rough", 0.3, "smooth"):
        result = Cel2DSolver(build_scene(compose_cfg([*base, f"geometry.roughness={r}"]))).solve()
        assert result.status == "ok" and result.metrics["energy_error"] < 0.02, result.message
        sinkage.append(result.metrics["max_sinkage_m"])
    assert sinkage[0] < sinkage[1] < sinkage[2], sinkage  # medium mesh, su0 3 kPa: 0.1298, 0.1300, 0.1309 m


def test_a_cone_refuses_limited_adhesion(compose_cfg):
    with pytest.raises(ConfigError, match="flat-faced body"):
        build_scene(compose_cfg(["solver=cel2d", "geometry=fall_cone_30deg", "geometry.roughness=0.5"]))


def test_a_face_grips_a_partly_filled_cell_in_proportion_to_its_fill():
    """The grip per unit su at a wall node: φ·su averaged over its cells outside the body. A cell
    at the mudline a fifth full grips a fifth as hard (at full su it dragged the soil down)."""
    import numpy as np

    from dsmv.cel.contact import grip_cells
    from dsmv.cel.kernels.nodes import grip_strength
    from dsmv.cel.layout import Cells, Contact

    su_pa = 10_000.0
    solid = np.array([[True, True], [False, False]])  # the body left of the node, soil right of it
    phi = np.array([[0.0, 0.0], [1.0, 0.2]])  # below the node full, above it a fifth
    start, cells = grip_cells(solid, (np.array([1]), np.array([1])), [])  # the tie at node (1, 1)
    none = np.zeros(0, dtype=np.int64)
    contact = Contact(np.array([4]), np.array([False]), np.array([[1.0, 0.0]]), np.array([1.0]), start, cells,
                      np.ones(1), none, none, none, none, np.zeros((0, 4), dtype=np.int64), np.zeros((1, 2)),
                      np.zeros(1))

    def grip():
        state = Cells(phi, np.zeros((6, 2, 2)), np.where(phi > 0.0, su_pa, 0.0), np.ones((2, 2)), solid,
                      1.0 - solid, np.zeros((2, 2), dtype=bool), np.full((2, 2), np.nan), np.ones((2, 2)))
        return grip_strength(contact, state, 0)

    assert grip() == pytest.approx(0.5 * (1.0 + 0.2) * su_pa)
    phi[1, 1] = 1.0
    assert grip() == pytest.approx(su_pa)  # fully in contact: su


@pytest.mark.parametrize("overrides, parts", [
    (["solver=cel2d"], True),                                             # the default landing: a track section
    (["solver=cel2d", "geometry=strip"], True),                           # a strip landing
    (["solver=cel2d", "geometry=tbar", "geometry.roughness=smooth"], True),  # a smooth cylinder's cut cells
    (["solver=cel2d", "geometry=tbar"], False),                           # a rough cylinder: staircase, tied
    (["solver=cel2d", "geometry=fall_cone_30deg"], False),                 # a staircase cone stays tied
    (["solver=cel2d", "geometry.view=longitudinal"], False),              # plates and grousers: staircase
    (["solver=cel2d", "solver.economies.symmetry=false"], True),          # the whole section lets go as the half
    ([*canonical.PRANDTL_BONDED[:-1], "solver.contact_separation=auto"], False),  # a push stays tied unless asked
])
def test_auto_separation_lets_go_in_landings_wherever_faces_can(compose_cfg, overrides, parts):
    """solver.contact_separation=auto: real contact holds no tension, so a landing's soil may part from
    the body wherever its faces can let go; the verification pushes keep their tied contact."""
    from dsmv.cel.contact import ContactRules

    scene = build_scene(compose_cfg(overrides))
    assert ContactRules.of(scene, Cel2DSolver.is_axisymmetric(scene)).separation is parts
