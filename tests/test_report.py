"""The verification report's arithmetic and page, on synthetic outcomes (``dsmv-report --quick`` runs in CI)."""

import math
import re

import pytest

from dsmv.verify import report

#: a fenced code block of a Markdown page
FENCE = re.compile(r"^(```|~~~).*?^\1", re.MULTILINE | re.DOTALL)


def _outcomes(reference, constant, order, cells):
    return [report.Outcome(h, "ok", reference + constant * h**order, 1.0) for h in cells]


def test_a_sequence_that_converges_at_second_order_extrapolates_to_its_limit(tmp_path):
    """z(h) = z* + C·h² on three meshes halving: the observed order is 2 and the extrapolated value z*
    to round-off; the page states both, the error per mesh, and the commit it measured."""
    check = report.Check("a_test", "A test check, q/su", "nc_at_0p05B", 5.0, "a truth", (), (0.025, 0.05, 0.1), None, 1.0)
    outcomes = _outcomes(5.0, 40.0, 2.0, check.cells_m)
    estimate = report.estimate(outcomes)
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
    # the pages quote these numbers by the check's key
    assert report.fill_figures("q/su {{ report.a_test.value }} ({{report.a_test.error:+.1f }} %) at B/40, "
                               "{{ report.a_test.value@0.1:.3f }} at B/10, order {{ report.a_test.order:.2f }}",
                               numbers) == "q/su 5.025 (+0.5 %) at B/40, 5.400 at B/10, order 2.00"


def test_without_a_reference_the_error_is_against_the_extrapolated_value():
    check = report.Check("a_landing", "A landing", "max_sinkage_m", None, "itself", (), (0.01, 0.02, 0.04), None, 1.0)
    outcomes = _outcomes(0.1, -0.5, 1.0, check.cells_m)  # 0.095, 0.09, 0.08: first order towards 0.1
    section, row = report.check_section(check, outcomes)
    assert row["reference"] == "0.1" and row["order"] == "1.00"
    assert row["error"] == f"{100 * (0.095 / 0.1 - 1):+.2f} %"


def test_a_run_that_did_not_end_ok_is_shown_and_left_out_of_the_estimate():
    check = report.Check("a_push", "A push", "nc_at_0p05B", 5.0, "a truth", (), (0.025, 0.05, 0.1, 0.2), None, 1.0)
    outcomes = [report.Outcome(0.025, "unstable", math.nan, 2.0), *_outcomes(5.0, 1.0, 1.0, (0.05, 0.1, 0.2))]
    section, row = report.check_section(check, outcomes)
    assert "| 0.025 m | 40 | unstable |" in section
    assert row["finest"] == "5.05 (B/20)" and row["order"] == "1.00"


def test_the_derived_figures_read_the_runs_signs():
    """A run reports −H and −M (the soil's reaction on the body); the figures derived from them are 1 on
    Green's envelope and on the effective width's curve, whichever way the strip was pushed or turned."""
    from dsmv.analytic.bearing import effective_width_moment, green_vertical

    for sign in (1.0, -1.0):
        on_green = {"end_horizontal_factor": -sign * 0.5, "end_vertical_factor": green_vertical(0.5)}
        assert report.DERIVED["green_radial_factor"](on_green) == pytest.approx(1.0, abs=1e-9)
        on_width = {"end_moment_factor": -sign * effective_width_moment(2.0), "end_vertical_factor": 2.0}
        assert report.DERIVED["effective_width_factor"](on_width) == pytest.approx(1.0, abs=1e-12)
        # turned either way, H towards the edge pressed down raises the scoop's bound: mirrored, one figure
        from dsmv.analytic.bearing import bonded_moment_upper_bound

        on_scoop = {"end_moment_factor": sign * bonded_moment_upper_bound(3.3, 0.05), "end_vertical_factor": 3.3,
                    "end_horizontal_factor": sign * 0.05}
        assert report.DERIVED["scoop_factor"](on_scoop) == pytest.approx(1.0, abs=1e-9)
    beyond = {"end_horizontal_factor": -1.1, "end_vertical_factor": 0.0}  # a slide 10 % over B·su
    assert report.DERIVED["green_radial_factor"](beyond) == pytest.approx(1.1, abs=1e-9)


def test_the_figure_draws_more_checks_than_its_palette_has_colours(tmp_path):
    """A report of 30 checks, the palette 20 colours: the figure is drawn (a report of 24 checks had lost
    its page to an index past the palette)."""
    checks = [report.Check(f"c{k}", f"Check {k}", "nc", 5.0, "a truth", (), (0.025, 0.05, 0.1), None, 1.0)
              for k in range(30)]
    results = [(check, _outcomes(5.0, 1.0 + k, 1.0, check.cells_m)) for k, check in enumerate(checks)]
    assert report.figure(tmp_path / "f.png", results).stat().st_size > 10_000


def test_a_figure_the_report_does_not_have_fails_in_one_line():
    """A page that quotes a check, a figure or a mesh the report has not measured cannot build."""
    numbers = {"checks": [{"key": "a_push", "name": "A push", "metric": "nc_at_0p05B", "reference": 5.0,
                           "outcomes": [{"cell_m": 0.1, "status": "ok", "value": 4.9, "wall_s": 1.0}]}]}
    assert report.fill_figures("{{ report.a_push.error:.1f }}", numbers) == "−2.0"
    for text, words in (("{{ report.b_push.value }}", "no such check; the report has a_push"),
                        ("{{ report.a_push.mass }}", "no such figure"),
                        ("{{ report.a_push.value@0.05 }}", "no mesh of that core cell ended ok"),
                        ("{{ report.a_push.order }}", "fewer than three meshes")):
        with pytest.raises(ValueError, match=words):
            report.fill_figures(text, numbers)


def test_every_figure_the_pages_quote_is_in_the_committed_report():
    """The site's pages quote the report's figures (mkdocs.yml's hook fills them in): each one must
    be in docs/verification/report.json, so that the strict build cannot fail on a missing one."""
    from pathlib import Path

    docs = Path(__file__).resolve().parent.parent / "docs"
    numbers = report.committed_numbers(docs)
    quoted = 0
    for page in docs.rglob("*.md"):
        text = page.read_text()
        quoted += len(report.FIGURE_PLACEHOLDER.findall(text))
        report.fill_figures(text, numbers)  # raises on a figure the report does not have
    assert quoted > 0


def test_no_page_retypes_a_figure_the_report_measured():
    """A figure the report measured is quoted ({{ report.… }}), never typed: no page but the report
    itself shows one of its values (to 4 or 5 significant digits) outside its code blocks (a
    command's example output may show the default landing). The decision records are exempt: they
    keep the measurements that decided them, taken on the code of their day."""
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent
    numbers = report.committed_numbers(root / "docs")

    def significant(text: str) -> int:
        return len(re.sub(r"\D", "", text).lstrip("0"))

    figures = {format(o["value"], spec) for check in numbers["checks"] for o in check["outcomes"]
               if o["status"] == "ok" for spec in (".4g", ".5g")}
    figures = {f for f in figures if significant(f) >= 4}
    pages = [p for p in [root / "README.md", *(root / "docs").rglob("*.md")]
             if p.name != "report.md" and "decisions" not in p.parts]
    retyped = [f"{page.relative_to(root)}: {figure}" for page in pages for figure in figures
               if re.search(rf"(?<![\d.]){re.escape(figure)}(?!\d)", FENCE.sub("", page.read_text()))]
    assert not retyped, retyped


def test_checks_rerun_alone_are_merged_into_the_report_each_with_its_commit(tmp_path, monkeypatch, capsys):
    """``dsmv-report --only KEY`` reruns that check and keeps every other one the committed report holds,
    with its outcomes and the commit that measured it; the page names both commits, and each section its
    own. A check the report held that no longer exists is dropped."""
    import json

    first = report.Check("first", "First check", "nc_at_0p05B", 5.0, "a truth", (), (0.025, 0.05, 0.1), None, 1.0)
    second = report.Check("second", "Second check", "nc_at_0p05B", 5.0, "a truth", (), (0.025, 0.05, 0.1), None, 1.0)
    old = {"commit": "0ld0ld0ld0", "tree": "clean", "date": "2026-01-01 00:00 UTC", "machine": "a machine"}
    new = {"commit": "5e5e5e5e5e", "tree": "clean", "date": "2026-02-01 00:00 UTC", "machine": "a machine"}
    page = tmp_path / "report.md"
    report.write_page(page, [(first, _outcomes(5.0, 40.0, 2.0, first.cells_m)),
                             (second, _outcomes(5.0, 40.0, 2.0, second.cells_m))], quick=False, stamp=old)
    stored = json.loads(page.with_suffix(".json").read_text())
    stored["checks"].append({**stored["checks"][0], "key": "gone"})
    page.with_suffix(".json").write_text(json.dumps(stored))
    monkeypatch.setattr(report, "PAGE", page)
    monkeypatch.setattr(report, "CHECKS", (first, second))
    monkeypatch.setattr(report, "provenance", lambda: new)
    monkeypatch.setattr(report, "run", lambda check, cell: report.Outcome(cell, "ok", 5.0 + 20.0 * cell**2, 2.0))
    monkeypatch.setattr(report, "estimated_wall_s", lambda check, cell: 40.0)
    assert report.main(["--only", "second"]) == 0
    said = capsys.readouterr().out  # the plan and each run's estimate before it runs
    assert "dsmv-report: 1 check, 3 runs, about 2 min by the solvers' estimates" in said
    assert said.index("second at 0.025 m, about 40 s ...") < said.index("Second check at 0.025 m: ok")
    numbers = json.loads(page.with_suffix(".json").read_text())
    assert [c["key"] for c in numbers["checks"]] == ["first", "second"]
    assert [c["stamp"]["commit"] for c in numbers["checks"]] == ["0ld0ld0ld0", "5e5e5e5e5e"]
    assert numbers["checks"][0]["outcomes"] == stored["checks"][0]["outcomes"]
    assert numbers["checks"][1]["outcomes"][0]["value"] == 5.0 + 20.0 * 0.025**2
    text = page.read_text()
    assert "- commit `5e5e5e5e5e` (clean tree), 2026-02-01 00:00 UTC: 1 check" in text
    assert "- commit `0ld0ld0ld0` (clean tree), 2026-01-01 00:00 UTC: 1 check" in text
    assert text.count("Measured on commit `0ld0ld0ld0`") == 1 and text.count("Measured on commit `5e5e5e5e5e`") == 1


def test_an_interrupted_report_keeps_the_checks_done_in_a_folder_it_makes(tmp_path, monkeypatch):
    """SIGINT or SIGTERM during a run: the report stops after it and writes what it has under runs/report/,
    made if missing (a fresh checkout has none), and exits with the code of ``interrupted``."""
    import json

    from dsmv.results import EXIT_CODES

    first = report.Check("first", "First check", "nc_at_0p05B", 5.0, "a truth", (), (0.025, 0.05, 0.1), None, 1.0)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(report, "CHECKS", (first,))
    monkeypatch.setattr(report, "PAGE", tmp_path / "docs" / "report.md")
    monkeypatch.setattr(report, "provenance", lambda: {"commit": "5e5e5e5e5e", "tree": "clean", "date": "today",
                                                       "machine": "a machine"})
    monkeypatch.setattr(report, "estimated_wall_s", lambda check, cell: 1.0)
    monkeypatch.setattr(report, "run", lambda check, cell: report.Outcome(
        cell, "ok" if cell < 0.04 else "interrupted", 5.0 if cell < 0.04 else float("nan"), 1.0))
    assert not (tmp_path / "runs").exists()
    assert report.main(["--only", "first"]) == EXIT_CODES["interrupted"]
    kept = json.loads((tmp_path / "runs" / "report" / "report.interrupted.json").read_text())
    assert [o["status"] for o in kept["checks"][0]["outcomes"]] == ["ok", "interrupted"]


def test_a_check_whose_scene_does_not_compose_stops_the_report_in_one_line(tmp_path, monkeypatch, capsys):
    """A check's overrides that a scene refuses: one line naming the key, the value and what is allowed,
    exit 2, before any run; a fine mesh's run time is no refusal (the report states its estimate first)."""
    bad = report.Check("bad", "A bad check", "nc_at_0p05B", 5.0, "a truth",
                       (*report.SMALL_STRAIN, "geometry.roughness=sticky"), (0.1,), None, 1.0)
    monkeypatch.setattr(report, "CHECKS", (bad,))
    monkeypatch.setattr(report, "PAGE", tmp_path / "report.md")
    assert report.main(["--only", "bad"]) == 2
    said = capsys.readouterr()
    assert said.out == "" and len(said.err.strip().splitlines()) == 1
    assert "geometry.roughness" in said.err and "sticky" in said.err
    # a 3D circle on D/40 cells is estimated at about an hour (on these machines 38 to 71 min), near or past
    # cel3d's default refusal of 3600 s: the report's runs are not refused by run time
    fine = report.Check("fine", "A fine 3D check", "end_moment_factor", 0.67, "a truth",
                        (*report.SMALL_STRAIN, "solver=cel3d", "geometry=circular_plate", "landing.velocity_m_s=0",
                         "landing.roll_rate_rad_s=0.1", "landing.rotation_deg=4", "landing.free=[x,y,z]"),
                        (0.025,), None, 1.0, "D")
    assert report.solver_of(fine, 0.025).scene.solver.max_wall_s == report.NO_WALL_LIMIT_S > 1e6
