"""Figures: the resistance's moving mean, the history figure and its smoothed trace, the field figure's notes."""

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


def test_the_strength_panel_says_that_su_above_the_intact_strength_is_the_rate_effect(tmp_path, monkeypatch):
    """At the deepest frame the body rests but the soil still shears, so Einav–Randolph's rate factor
    keeps su above su0 + ks·z: the su panel's title says so, lest it be read as an error."""
    from matplotlib.figure import Figure

    from dsmv.cel.fields import Frame
    from dsmv.post import plots

    x, y = np.linspace(0.0, 1.0, 11), np.linspace(-1.0, 0.5, 16)
    shape = (len(x) - 1, len(y) - 1)
    soil = np.broadcast_to(0.5 * (y[1:] + y[:-1]) < 0.0, shape).astype(float)
    cells = {"volume_fraction": soil, "su_pa": 7500.0 * soil, "body": np.zeros(shape),
             "plastic_shear_strain": np.zeros(shape), "shear_strain_rate_per_s": np.full(shape, 0.3)}
    frame = Frame(x, y, cells, np.zeros((len(x), len(y), 2)), 0.09, 0.065)
    titles = []
    save = Figure.savefig

    def keep_titles(fig, *args, **kwargs):
        titles.extend(ax.get_title() for ax in fig.axes if ax.get_title())
        return save(fig, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", keep_titles)
    plots._plot_section(frame, [], tmp_path / "fields.png", "a title")
    assert titles[0].startswith("undrained strength su") and titles[0].endswith(plots.SU_NOTE)
    assert "rate effect" in plots.SU_NOTE and "su0 + ks·z" in plots.SU_NOTE
