"""The soil a track's grousers trap holds under contact separation (docs/decisions/0042): soil against soil
does not part in undrained clay, while the steel above it lets go of soil that pulls away."""

from __future__ import annotations

import numpy as np
import pytest

from dsmv.cel.kernels.nodes import ties_that_hold
from dsmv.cel.layout import N_BODY, Contact, Nodes
from dsmv.cel.solver3d import Cel3DSolver
from dsmv.config.scene import build_scene

QUIET = ["tracking=disabled", "output.plots=false", "solver.progress=off"]


def _face_ties(bonded):
    """Two ties on a wall facing +x (normal into the soil), the body at rest, one node each."""
    none = np.zeros(0, dtype=np.int64)
    n = len(bonded)
    return Contact(np.arange(n, dtype=np.int64), np.zeros(n, dtype=bool), np.tile([1.0, 0.0, 0.0], (n, 1)),
                   np.zeros(n), np.zeros(n + 1, dtype=np.int64), np.zeros((0, 3), dtype=np.int64),
                   np.ones(n, dtype=bool), none, none, none, none, np.zeros((0, 6), dtype=np.int64),
                   np.zeros((n, 3)), np.asarray(bonded, dtype=bool))


@pytest.mark.parametrize("speed", [0.2, -0.2])
def test_a_bonded_tie_holds_soil_that_pulls_away_and_a_steel_one_lets_it_go(speed):
    """Soil moving off the wall (+x, away from the body) at 0.2 m/s: the steel's tie lets go, the trapped
    soil's holds; moving onto it, both hold."""
    contact = _face_ties([True, False])
    nodes = Nodes(np.array([[speed, speed], [0.0, 0.0], [0.0, 0.0]]), np.zeros((3, 2)), np.ones(2), np.zeros((3, 2)))
    ties_that_hold(contact, nodes, 1e-4, 0.0, (0.0, 0.0), 1e-12, np.zeros(N_BODY))
    assert contact.holding.tolist() == [True, speed < 0.0]


def _plate_contact(compose_cfg, *overrides):
    scene = build_scene(compose_cfg([*QUIET, "solver=cel3d", "mesh.cell_size_m=0.05", *overrides]))
    solver = Cel3DSolver(scene)
    grid = solver.build()
    contact = solver.body_contact(grid).contact
    heights = grid.z[np.unravel_index(contact.node[:len(contact.node) - len(contact.split_node)],
                                      tuple(len(a) for a in grid.axes))[2]] - grid.z[grid.row_of(0.0)]
    return scene, contact, heights


def test_the_ties_within_the_grouser_height_of_a_3d_tracks_base_are_bonded(compose_cfg):
    """On 0.05 m cells the 0.05 m grousers' envelope bonds the base's ties, their edge's split copies and
    the wall's first row above (on the grousers' height); the walls above it, steel, may let go."""
    scene, contact, heights = _plate_contact(compose_cfg)
    gh = scene.geometry.grouser_height_m
    grid_ties = len(heights)
    assert contact.bonded[:grid_ties].tolist() == (heights <= gh + 1e-12).tolist()
    assert contact.bonded[grid_ties:].all() and len(contact.split_node) > 0
    assert {round(z, 9) for z in heights[contact.bonded[:grid_ties]]} == {0.0, round(gh, 9)}
    assert (~contact.bonded).sum() > 0  # the steel above the grousers


def test_a_track_whose_grousers_are_cells_bonds_nothing(compose_cfg):
    """Drawn as cells (their steel in the grid), the grousers trap no modelled soil."""
    _, contact, _ = _plate_contact(compose_cfg, "geometry.grousers=cells")
    assert not contact.bonded.any()
