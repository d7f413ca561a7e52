"""The verification report's arithmetic and page, on synthetic outcomes (``dsmv-report --quick`` runs in CI)."""

import math

import pytest

from dsmv import report


def _outcomes(reference, constant, order, cells):
    return [report.Outcome(h, "ok", reference + constant * h**order, 1.0) for h in cells]


def test_a_sequence_that_converges_at_second_order_extrapolates_to_its_limit(tmp_path):
    """z(h) = z* + C·h² on three meshes halving: the observed order is 2 and the extrapolated value z*
    to round-off; the page states both, the error per mesh, and the commit it measured."""
    check = report.Check("A test check, q/su", "nc_at_0p05B", 5.0, "a truth", (), (0.025, 0.05, 0.1), None, 1.0)
    outcomes = _outcomes(5.0, 40.0, 2.0, check.cells_m)
    estimate = report.estimate(check, outcomes)
    assert estimate.order == pytest.approx(2.0, rel=1e-6) and estimate.extrapolated == pytest.approx(5.0, rel=1e-9)
    stamp = {"commit": "0123abc", "tree": "clean", "date": "2026-01-01 00:00 UTC", "machine": "a machine"}
    page = report.write_page(tmp_path / "report.md", [(check, outcomes)], quick=True, stamp=stamp)
    text = page.read_text()
    assert "commit `0123abc` (clean tree)" in text
    assert "| 0.025 m | 40 | 5.025 | +0.50 % |" in text  # 5 + 40·0.025² = 5.025
    assert "Observed order 2.00; extrapolated 5 ± " in text
    assert (tmp_path / report.FIGURE).stat().st_size > 10_000
    import json

    numbers = json.loads((tmp_path / "report.json").read_text())
    assert numbers["stamp"]["commit"] == "0123abc" and numbers["checks"][0]["outcomes"][0]["value"] == 5.025


def test_without_a_reference_the_error_is_against_the_extrapolated_value():
    check = report.Check("A landing", "max_sinkage_m", None, "itself", (), (0.01, 0.02, 0.04), None, 1.0)
    outcomes = _outcomes(0.1, -0.5, 1.0, check.cells_m)  # 0.095, 0.09, 0.08: first order towards 0.1
    section, row = report.check_section(check, outcomes)
    assert row["reference"] == "0.1" and row["order"] == "1.00"
    assert row["error"] == f"{100 * (0.095 / 0.1 - 1):+.2f} %"


def test_a_run_that_did_not_end_ok_is_shown_and_left_out_of_the_estimate():
    check = report.Check("A push", "nc_at_0p05B", 5.0, "a truth", (), (0.025, 0.05, 0.1, 0.2), None, 1.0)
    outcomes = [report.Outcome(0.025, "unstable", math.nan, 2.0), *_outcomes(5.0, 1.0, 1.0, (0.05, 0.1, 0.2))]
    section, row = report.check_section(check, outcomes)
    assert "| 0.025 m | 40 | unstable |" in section
    assert row["finest"] == "5.05 (B/20)" and row["order"] == "1.00"
