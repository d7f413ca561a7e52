"""The soil a track's grousers trap holds under contact separation (docs/decisions/0042): soil against soil
does not part in undrained clay, while the steel above it lets go of soil that pulls away. A tie holds
the share of its face the trapped soil covers."""

from __future__ import annotations

import numpy as np
import pytest

from dsmv.cel.contact import trapped_shares
from dsmv.cel.kernels.nodes import (apply_ties, catch_up_of_shared_ties, rigid_velocity, tie_reactions,
                                    ties_that_hold)
from dsmv.cel.layout import B_VEL, B_WY, N_BODY, Contact, Nodes
from dsmv.cel.solver3d import Cel3DSolver
from dsmv.config.scene import build_scene

QUIET = ["tracking=disabled", "output.plots=false", "solver.progress=off"]


def _face_ties(bond, normal=(1.0, 0.0, 0.0)):
    """Ties on a wall facing +x (normal into the soil), the body at rest, one node each, ``bond`` the
    share of each that is trapped soil."""
    none = np.zeros(0, dtype=np.int64)
    n = len(bond)
    return Contact(np.arange(n, dtype=np.int64), np.zeros(n, dtype=bool), np.tile(normal, (n, 1)),
                   np.zeros(n), np.zeros(n + 1, dtype=np.int64), np.zeros((0, 3), dtype=np.int64),
                   np.ones(n), none, none, none, none, np.zeros((0, 6), dtype=np.int64),
                   np.zeros((n, 3)), np.asarray(bond, dtype=float))


@pytest.mark.parametrize("speed", [0.2, -0.2])
def test_a_trapped_share_of_a_tie_holds_soil_that_pulls_away_and_the_steel_lets_it_go(speed):
    """Soil moving off the wall (+x, away from the body) at 0.2 m/s: the steel's tie lets go, the trapped
    soil's holds, a tie 40 % trapped holds 40 % of its node; moving onto the wall, all hold."""
    contact = _face_ties([1.0, 0.0, 0.4])
    nodes = Nodes(np.array([[speed] * 3, [0.0] * 3, [0.0] * 3]), np.zeros((3, 3)), np.ones(3), np.zeros((3, 3)))
    ties_that_hold(contact, nodes, 1e-4, 0.0, (0.0, 0.0), 1e-12, np.zeros(N_BODY))
    assert contact.holding.tolist() == ([1.0, 0.0, 0.4] if speed > 0.0 else [1.0, 1.0, 1.0])


@pytest.mark.parametrize("share", [1.0, 0.4])
def test_a_tie_holding_a_share_of_its_node_keeps_the_momentum_of_body_and_node(share):
    """The inelastic collision of the body (10 kg, falling at 1 m/s) with a node (2 kg, at rest) its base
    holds a share of, as :func:`dsmv.cel.stepper.rejoin_ties` solves it: the body takes (M·V + s·m·v)/(M + s·m)
    from the tie's momentum and inertia, the tie moves the node s of the way. Momentum is conserved to
    round-off and kinetic energy does not grow."""
    body_kg, node_kg, body_m_s, node_m_s = 10.0, 2.0, -1.0, 0.0
    contact = _face_ties([share], normal=(0.0, 0.0, -1.0))
    contact.holding[:] = share
    nodes = Nodes(np.array([[0.0], [0.0], [node_m_s]]), np.zeros((3, 1)), np.array([node_kg]), np.zeros((3, 1)))
    momentum, inertia = np.zeros(6), np.zeros((6, 6))
    tie_reactions(contact, nodes, 0.0, (0.0, 0.0), momentum, inertia, True)
    body = np.zeros(N_BODY)
    body[B_VEL] = (body_kg * body_m_s + momentum[2]) / (body_kg + inertia[2, 2])
    apply_ties(contact, nodes, body)
    before = body_kg * body_m_s + node_kg * node_m_s
    after = body_kg * body[B_VEL] + node_kg * nodes.v[2, 0]
    assert abs(after - before) <= 1e-12 * abs(before)
    kinetic = 0.5 * body_kg * body[B_VEL] ** 2 + 0.5 * node_kg * nodes.v[2, 0] ** 2
    assert kinetic <= 0.5 * body_kg * body_m_s ** 2
    assert (nodes.v[2, 0] == body[B_VEL]) == (share == 1.0)  # a whole tie carries its node with the body


@pytest.mark.parametrize("share,lag", [(1.0, 0.0), (0.4, 0.3), (0.9, -0.2)])
@pytest.mark.parametrize("full", [True, False])
def test_a_step_with_a_shared_tie_changes_the_momentum_by_the_forces_alone(share, lag, full):
    """One explicit step of the body (10 kg under 50 N down, falling at 1 m/s and turning at 2 rad/s about
    y) and a node (2 kg, 8 N on it) its tie holds a share of, as a step runs them: the body moves under
    its force, the ties' reactions and their catch-up (:func:`catch_up_of_shared_ties`) with the tied
    inertia, the node under its force, then the tie. A shared tie's node lags the body's point (``lag``,
    m/s up); a whole one's does not (its tie closed the lag the step before). The vertical momentum of the
    two changes by the forces' impulse alone, to round-off."""
    dt, body_kg, weight_n, node_kg, node_n = 1e-3, 10.0, -50.0, 2.0, 8.0
    contact = _face_ties([share], normal=(0.0, 0.0, -1.0))
    contact = contact._replace(full=np.array([full]), arm=np.array([[0.3, 0.0, -0.2]]))
    contact.holding[:] = share
    body = np.zeros(N_BODY)
    body[B_VEL], body[B_WY] = -1.0, 2.0
    point = np.array([rigid_velocity(body, contact.arm, 0, a) for a in range(3)])
    nodes = Nodes((point + [0.1 * lag, 0.0, lag])[:, None], np.array([[0.0], [0.0], [node_n]]), np.array([node_kg]),
                  np.zeros((3, 1)))
    before = body_kg * body[B_VEL] + node_kg * nodes.v[2, 0]
    force, inertia = np.zeros(6), np.zeros((6, 6))
    tie_reactions(contact, nodes, 0.0, (0.0, 0.0), force, inertia)
    catch_up_of_shared_ties(contact, nodes, body, dt, force)
    body[B_VEL] += dt * (weight_n + force[2]) / (body_kg + inertia[2, 2])  # the vertical freedom alone is free
    nodes.v[:, 0] += dt * nodes.f[:, 0] / node_kg
    apply_ties(contact, nodes, body)
    after = body_kg * body[B_VEL] + node_kg * nodes.v[2, 0]
    assert after - before == pytest.approx(dt * (weight_n + node_n), rel=1e-9)


@pytest.mark.parametrize("h", [0.1, 0.075, 0.05, 0.04, 0.0375, 0.025])
def test_the_held_wall_measures_the_grouser_height_on_any_mesh(h):
    """A wall's nodes every h from the base stand for the face from z − h/2 to z + h/2 (the base's, from
    0 to h/2): their trapped shares add up to the grousers' 0.05 m on any cell up to twice it. Whole
    nodes held a wall that stepped with the cell: 0.0375 m on 0.075 m cells, 0.05625 m on 0.0375 m."""
    gh = 0.05
    heights = h * np.arange(0, 20)
    shares = trapped_shares(heights, gh, h)
    wall = np.where(heights == 0.0, 0.5 * h, h)  # the face each node stands for
    assert np.sum(shares * wall) == pytest.approx(gh, rel=1e-12)
    assert shares[0] == 1.0 and np.all(np.diff(shares) <= 0.0)


def _plate_contact(compose_cfg, *overrides):
    scene = build_scene(compose_cfg([*QUIET, "solver=cel3d", "mesh.cell_size_m=0.05", *overrides]))
    solver = Cel3DSolver(scene)
    grid = solver.build()
    contact = solver.body_contact(grid).contact
    heights = grid.z[np.unravel_index(contact.node[:len(contact.node) - len(contact.split_node)],
                                      tuple(len(a) for a in grid.axes))[2]] - grid.z[grid.row_of(0.0)]
    return scene, contact, heights


def test_the_ties_within_the_grouser_height_of_a_3d_tracks_base_hold_their_trapped_share(compose_cfg):
    """On 0.05 m cells the 0.05 m grousers' envelope holds the base's ties and their edge's split copies
    whole, half of the wall's first row above (on the grousers' height, standing for 0.025 to 0.075 m);
    the walls above it, steel, may let go."""
    scene, contact, heights = _plate_contact(compose_cfg)
    gh = scene.geometry.grouser_height_m
    grid_ties = len(heights)
    expected = np.select([heights < 1e-9, np.abs(heights - gh) < 1e-9], [1.0, 0.5], 0.0)
    assert contact.bond[:grid_ties].tolist() == pytest.approx(expected.tolist(), abs=1e-12)
    assert np.all(contact.bond[grid_ties:] == 1.0) and len(contact.split_node) > 0
    assert (contact.bond == 0.0).sum() > 0 and np.isclose(contact.bond, 0.5).sum() > 0  # steel above, half a node


def test_a_track_whose_grousers_are_cells_bonds_nothing(compose_cfg):
    """Drawn as cells (their steel in the grid), the grousers trap no modelled soil."""
    _, contact, _ = _plate_contact(compose_cfg, "geometry.grousers=cells")
    assert not contact.bond.any()
