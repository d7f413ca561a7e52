"""Figures: the resistance's moving mean, the history figure and its smoothed trace."""

import numpy as np
import pytest

from dsmv.post.plots import moving_mean, plot_history


def test_the_moving_mean_keeps_what_a_centred_mean_keeps():
    """A centred mean leaves a linear trace unchanged away from the ends, and a constant everywhere;
    on uneven spacing too. A trace ringing about a level, averaged over whole periods, gives the level."""
    t = np.sort(np.random.default_rng(3).uniform(0.0, 1.0, 400))
    t = np.concatenate([t, 1.0 - t[::-1]])  # symmetric samples: every interior window is centred on its sample
    assert moving_mean(t, np.full_like(t, 7.0), 0.1) == pytest.approx(7.0, rel=1e-12)
    uniform = np.linspace(0.0, 1.0, 1001)
    ramp = moving_mean(uniform, 3.0 * uniform - 1.0, 0.101)  # edges between samples: 50 each side
    interior = (uniform > 0.06) & (uniform < 0.94)
    assert ramp[interior] == pytest.approx(3.0 * uniform[interior] - 1.0, abs=1e-12)
    ringing = 5.0 + np.sin(2 * np.pi * uniform / 0.02)  # period 0.02 s: 20 samples
    mean = moving_mean(uniform, ringing, 0.101)  # 101 samples: five whole periods and one sample
    assert mean[interior] == pytest.approx(5.0, abs=1.0 / 101 + 1e-12)


def test_the_history_figure_draws_raw_and_smoothed_resistance(tmp_path):
    t = np.linspace(0.0, 0.1, 200)
    history = {"time_s": t, "sinkage_m": 0.5 * t, "force_n": 1e5 * (1 + 0.5 * np.sin(t / 0.001))}
    path = plot_history(history, tmp_path / "history.png", "a title")
    assert path.stat().st_size > 20_000
