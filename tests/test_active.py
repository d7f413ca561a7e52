"""Active learning: a space-filling start, then the candidates the forest's trees disagree on most."""

import numpy as np
import pytest

from dsmv.surrogate.active import DIVERSITY, ActiveConfig, candidates, choose, tree_spread
from dsmv.surrogate.dataset import TARGET_METRIC


@pytest.fixture(scope="module")
def pool():
    from dsmv.config.tree import compose_scene

    return candidates(compose_scene(["tracking=disabled"]), ActiveConfig(pool=60, seed=5))


def _tracked(pool, rows):
    """Rows of the pool as tracked runs, with a sinkage that depends on the scene (the fast model's
    energy scale)."""
    table = pool.iloc[rows].reset_index(drop=True).copy()
    table[TARGET_METRIC] = 0.05 * table["velocity_m_s"] * table["mass_kg"] / table["su0_pa"] ** 0.5
    return table


def test_the_start_is_the_hypercubes_first_candidates_not_yet_run(pool):
    active = ActiveConfig(initial=6, batch=4, pool=60, seed=5)
    rows, how = choose(pool, None, active)
    assert list(rows) == [0, 1, 2, 3, 4, 5] and "space-filling" in how
    rows, _ = choose(pool, _tracked(pool, [0, 2]), active)  # two already run: the next four unrun ones
    assert list(rows) == [1, 3, 4, 5]


def test_a_batch_is_drawn_from_the_most_disputed_unrun_candidates(pool):
    """Four new scenes, each among the 5·4 most disputed, one from each cluster of those."""
    active = ActiveConfig(initial=6, batch=4, pool=60, seed=5)
    tracked = _tracked(pool, list(range(10)))
    rows, how = choose(pool, tracked, active)
    assert len(rows) == 4 and len(set(rows)) == 4 and not set(rows) & set(range(10)) and "least sure" in how
    unrun = np.arange(10, len(pool))
    spread = tree_spread(tracked, pool.iloc[unrun].reset_index(drop=True), active.seed)
    disputed = unrun[np.argsort(-spread, kind="stable")[:DIVERSITY * 4]]
    assert set(rows) <= set(disputed)
    assert unrun[np.argmax(spread)] in rows  # the most disputed of all leads its cluster


def test_active_sweeps_add_batches_to_the_study(run_cli, tmp_path):
    """Two sweeps with the energy method (milliseconds a job): the start, then a batch of new scenes."""
    from dsmv.surrogate.dataset import load_dataset

    args = ("experiment=dataset_active", "active.initial=3", "active.batch=2", "active.pool=30",
            "solver=analytic_energy")
    first = run_cli("dsmv", *args)
    assert first.returncode == 0, first.stderr[-2000:]
    assert "space-filling start (0 of 3 runs tracked): running 3" in first.stdout
    second = run_cli("dsmv", *args)
    assert second.returncode == 0, second.stderr[-2000:]
    assert "2 of the 10 candidates (of 27) the forest on 3 runs is least sure of" in second.stdout
    table = load_dataset(f"sqlite:///{tmp_path / 'runs' / 'mlflow.db'}", "dataset_active").table
    assert len(table) == 5
    assert not table.drop(columns=["run_id", TARGET_METRIC]).duplicated().any()
