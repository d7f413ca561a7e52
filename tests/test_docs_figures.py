"""A figure quoted in more than one place says the same everywhere.

Every figure the docs quote has one home: the verification report (which the pages quote as
``{{ report.… }}``), a measured constant in the code, or the one page that measured it. Where the
README, another page, a config comment or a docstring quotes it again, the quote must agree with
the home and with every other quote. :data:`QUANTITIES` is the registry: for each quantity its
name, its home, the patterns that find its quotes (each with a group ``v``, the number) and, when
the home is a number the code can read, that number.

Quotes agree when one value can be read as each of them at the digits it is written with: 0.065,
0.0654 and 0.06545 all agree with the report's 0.065446; 0.0603 does not. The pages are read as
the site shows them, the report's figures filled in. The generated report and the decision records
are left out (the records keep the measurements of their day), and so is the changelog.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import pytest

from dsmv.convergence import first_order
from dsmv.verify import report

ROOT = Path(__file__).resolve().parent.parent
NUMBERS = report.committed_numbers(ROOT / "docs")


def from_report(key: str, field: str, cell_m: float | None = None, magnitude: bool = False) -> Callable[[], float]:
    """The report's figure (``report.<key>.<field>[@cell_m]``), or its magnitude: a page writes
    an error below the extrapolated value as "1.3 % below"."""
    def value() -> float:
        figure = report.figure_value(NUMBERS, key, field, cell_m)
        return abs(figure) if magnitude else figure

    return value


def from_code(module: str, name: str) -> Callable[[], float]:
    """A measured constant of the package."""
    def value() -> float:
        import importlib

        return float(getattr(importlib.import_module(module), name))

    return value


@dataclass(frozen=True)
class Quantity:
    """A figure the docs quote: ``patterns`` find its quotes (a pattern, or a pattern and the factor
    that turns its number into the quantity's unit); ``reference`` reads the home's own value."""

    name: str
    home: str
    patterns: tuple[str | tuple[str, float], ...]
    reference: Callable[[], float] | None = None


#: the default scene's line in a sample output (the README's and the guide's), in 2D and in 3D
SCENE = (r"scene\s+: nodule_field soil \(einav_randolph\), track_pioneer_i, "
         r"drop 4500 kg at 1\.5 m/s, solver {solver}\n")
DEFAULT_SCENE, DEFAULT_SCENE_3D = SCENE.format(solver="cel2d"), SCENE.format(solver="cel3d")

QUANTITIES = (
    Quantity("the default landing's max sinkage on the standard mesh (m)", "the report, landing_default at 0.02 m",
             (r"max sinkage (?P<v>[\d.]+) m(?: of the 2D cross-section)?\n\s+" + DEFAULT_SCENE,
              DEFAULT_SCENE + r"(?:.*\n)?\s+message : came to rest at (?P<v>[\d.]+) m",
              r'"message": "came to rest at (?P<v>[\d.]+) m after',
              r'"max_sinkage_m": (?P<v>[\d.]+),',
              r"`ok: max sinkage (?P<v>[\d.]+) m`",
              r"lands the default scene `ok` at (?P<v>[\d.]+) m",
              r"\(the CEL: (?P<v>[\d.]+) m\)",
              r"the 2D CEL \((?P<v>[\d.]+) m on the standard mesh\)",
              r"the default track (?:\([^)]*\) )?is [\d.]+ m² and\s+sinks (?P<v>[\d.]+) m",
              r"the default track \([^)]*\) sinks (?P<v>[\d.]+) m",
              r"^\| default \| (?P<v>[\d.]+) m \| [\d.]+ m \| [\d.]+ m \|$"),
             from_report("landing_default", "value", 0.02)),
    Quantity("the default landing's mesh error on the standard mesh (%)", "the report, landing_default at 0.02 m",
             (r"the default landing\s+reads (?P<v>[\d.]+) % below its extrapolated",
              r"sinkage reads (?P<v>[\d.]+)–[\d.]+ % below its value extrapolated",
              r"the default landing reads\s+[−+-]?(?P<v>[\d.]+) % from its extrapolated max sinkage on it"),
             from_report("landing_default", "error", 0.02, magnitude=True)),
    Quantity("the 3D track's mesh error on its default mesh (%)", "the report, track_3d at 0.075 m",
             (r"the 3D track on its default 0\.075 m cells reads (?P<v>[\d.]+) % above its",),
             from_report("track_3d", "error", 0.075)),
    Quantity("the Tresca landing's mesh error on the standard mesh (%)", "the report, landing_tresca at 0.02 m",
             (r"\(Tresca soil (?P<v>[\d.]+) %",),
             from_report("landing_tresca", "error", 0.02, magnitude=True)),
    Quantity("the mesh study's largest error on the standard mesh (%)",
             "docs/verification/landings.md, The default mesh",
             (r"the studies' extremes up to\s+(?P<v>[\d.]+) %",
              r"sinkage reads [\d.]+–(?P<v>[\d.]+) % below its value extrapolated",
              r"every scene of the mesh study is within\s+(?P<v>[\d.]+) % on it",
              r"every scene of the study is within (?P<v>[\d.]+) % of its extrapolated",
              r"Every scene is within (?P<v>[\d.]+) % of its extrapolated value at 0\.02 m")),
    Quantity("the default landing's cells on the standard mesh (half section)", "the sample output of `dsmv`",
             (r"(?P<v>[\d,]+) cells \([\d,]+ for the whole section\), [\d,]+ steps",
              r"^\s+(?P<v>[\d,]+) cells, about [\d,]+ steps, 1 MiB")),
    Quantity("the 3D track's max sinkage (the grousers' tips) on its default mesh, 0.075 m (m)",
             "the report, track_3d at 0.075 m",
             (r"max sinkage (?P<v>[\d.]+) m at the grouser tips, [\d.]+ m at the plates$",
              DEFAULT_SCENE_3D + r"(?:.*\n)?\s+message : came to rest at (?P<v>[\d.]+) m",
              r"^\| 0\.05 m \| (?P<v>[\d.]+) m \| [\d.]+ m \|$",
              r"^\| default \| [\d.]+ m \| (?P<v>[\d.]+) m \| [\d.]+ m \|$"),
             from_report("track_3d", "value", 0.075)),
    Quantity("the 3D track's plate sinkage on its default mesh (m)", "docs/verification/track-3d.md, Two sinkages",
             (r"(?P<v>[\d.]+) m at the plates$",
              r"^\| 0\.05 m \| [\d.]+ m \| (?P<v>[\d.]+) m \|$",
              r"against (?P<v>[\d.]+) m for the plates behind")),
    Quantity("the 3D track's cells on its default mesh (quarter model)", "the sample output of `make run`",
             (DEFAULT_SCENE_3D + r"(?:.*\n){0,2}\s+model\s+: (?P<v>[\d,]+) cells",
              r"^\s+(?P<v>[\d,]+) cells, about [\d,]+ steps, 13 MiB",
              r"B/8 across the track, (?P<v>[\d,]+) cells in the quarter model",
              r"0\.075 m core cells, (?P<v>[\d,]+) cells in the quarter model")),
    Quantity("the 3D track's steps on its default mesh", "the sample output of `make run`",
             (DEFAULT_SCENE_3D + r"(?:.*\n){0,2}\s+model\s+: [\d,]+ cells \([^)]*\), (?P<v>[\d,]+) steps",)),
    Quantity("field output on disk per cell and frame, 3D (B)", "dsmv.cel.cost.FIELD_BYTES_PER_CELL",
             (r"(?P<v>\d+) B per cell and frame in 3D",),
             lambda: __import__("dsmv.cel.cost", fromlist=["x"]).FIELD_BYTES_PER_CELL[3]),
    Quantity("field output on disk per cell and frame, 2D (B)", "dsmv.cel.cost.FIELD_BYTES_PER_CELL",
             (r"frame in 3D, (?P<v>\d+) B in 2D",),
             lambda: __import__("dsmv.cel.cost", fromlist=["x"]).FIELD_BYTES_PER_CELL[2]),
    Quantity("the 3D track's field output on its default mesh (MB)", "dsmv/cel/cost.py, FIELD_BYTES_PER_CELL",
             (r"3D coarse landing writes about (?P<v>\d+) MB",
              r"cells: (?P<v>\d+) MB in \d+ frames",
              r"frames\) writes (?P<v>\d+) MB")),
    Quantity("the 2D default landing's field output (MB)", "dsmv/cel/cost.py, FIELD_BYTES_PER_CELL",
             (r"cells: (?P<v>\d+\.\d+) MB in \d+ frames",
              r"frames\) writes (?P<v>\d+\.\d+) MB")),
    Quantity("the 3D track's max sinkage on B/16 cells (m)", "the report, track_3d at 0.0375 m",
             (r"dsmv: ok — max sinkage (?P<v>[\d.]+) m at the grouser tips, [\d.]+ m at the plates; extrapolated",
              r"m at the plates; extrapolated .*\n\s+message : came to rest at (?P<v>[\d.]+) m"),
             from_report("track_3d", "value", 0.0375)),
    Quantity("the 3D track's max sinkage extrapolated from B/16 and B/8 (m), solver.error_estimate's",
             "the report, track_3d at 0.0375 and 0.075 m, first order (dsmv.convergence.first_order)",
             (r"m at the plates; extrapolated (?P<v>[\d.]+) m ±",),
             lambda: first_order((0.0375, 0.075), (from_report("track_3d", "value", 0.0375)(),
                                                   from_report("track_3d", "value", 0.075)())).extrapolated),
    Quantity("the fast model's share of the 257 Table 3 landings within 10 % (%)",
             "docs/verification/landings.md, The fast landing model against the CEL",
             (r"(?P<v>\d+) % of the 257 Table 3 landings within 10 %",
              r"(?P<v>\d+) % of 257 \(\d+ % held out\)",
              r"\*\*(?P<v>\d+) % within 10 %\*\*")),
    Quantity("cel2d's two threads against one, the Prandtl push at B/20 (×)",
             "docs/verification/performance.md, Throughput",
             (r"Two threads take [\d.]+ s \((?P<v>[\d.]+)×",
              r"2 threads (?P<v>[\d.]+)×",
              r"the Prandtl push at B/20 runs (?P<v>[\d.]+)× as fast on two")),
    Quantity("the Prandtl push at B/20, warm solve (s)", "docs/verification/performance.md, Throughput",
             (r"loads the cache in [\d.]+ s and runs (?P<v>[\d.]+) s",
              r"warm (?P<v>[\d.]+) s, [\d.]+ M cell-updates/s")),
    Quantity("the Prandtl push at B/20, warm cell-updates per second (M/s)",
             "docs/verification/performance.md, Throughput",
             (r"loads the cache in [\d.]+ s and runs [\d.]+ s, (?P<v>[\d.]+) M cell-updates/s",
              r"warm [\d.]+ s, (?P<v>[\d.]+) M cell-updates/s")),
    Quantity("the Prandtl push at B/20, cold compile (s)", "docs/verification/performance.md, Throughput",
             (r"a cold start compiles for (?P<v>[\d.]+) s",
              r"cold (?P<v>[\d.]+) s compile")),
    Quantity("cel3d's fewest cells for parallel kernels", "dsmv.cel.solver3d.PARALLEL_MIN_CELLS",
             (r"one below (?P<v>[\d,]+) cells",
              r"Below (?P<v>[\d,]+) cells the kernels run on one thread",
              r"on grids of (?P<v>[\d,]+) cells and more"),
             from_code("dsmv.cel.solver3d", "PARALLEL_MIN_CELLS")),
    Quantity("cel3d's two threads against one at 4,275 cells (×)", "dsmv/cel/solver3d.py, PARALLEL_MIN_CELLS",
             (r"(?P<v>[\d.]+)× at\s+(?:#:\s*)?4,275 cells",)),
    Quantity("the pushed rough strip at B/20, q/su at 0.05 B (verify_prandtl)",
             "docs/verification/strip.md, Pushed to 1 B",
             (r"^\| B/20 \| [\d.]+ / [\d.]+ \| (?P<v>[\d.]+) \(",
              r"of 2 \+ π \| rough (?P<v>[\d.]+) \(\+[\d.]+ %\) and",
              r"\| Prandtl rough B/20 \(with the remap\) \| [\d.]+ \(\+[\d.]+ %\) \| (?P<v>[\d.]+) \(")),
    Quantity("the pushed rough strip at B/40, q/su at 0.05 B (verify_prandtl)",
             "docs/verification/strip.md, Pushed to 1 B",
             (r"^\| B/40 \| [\d.]+ / [\d.]+ \| (?P<v>[\d.]+) \(",
              r"of 2 \+ π \| rough [\d.]+ \(\+[\d.]+ %\) and (?P<v>[\d.]+) \(")),
    Quantity("compare_2d_3d with its mesh error estimates, wall time on two cores (min)",
             "docs/verification/track-3d.md, What the cross-section misses",
             (r"0\.075 m, first order; (?P<v>\d+) minutes on two\s+cores",
              r"dsmv experiment=compare_2d_3d \(about (?P<v>\d+) minutes on two cores\)")),
    Quantity("the 3D track's mesh study, the 0.02 m run's wall time (min)",
             "docs/verification/track-3d.md, The mesh study in 3D",
             ((r"\| 0\.02 m \| 1,191,400 \| [\d.]+ m \| — \| — \| (?P<v>\d+) s \|", 1 / 60),
              r"The 0\.02 m case, [\d.]+ M cells in the quarter model, takes (?P<v>\d+) minutes")),
)


# --------------------------------------------------------------------------- the machinery

@dataclass(frozen=True)
class Quote:
    """One quote of a quantity: where, as written, and the interval of values it can be read as."""

    where: str
    text: str
    low: float
    high: float


def read_number(text: str, factor: float = 1.0) -> tuple[float, float]:
    """The values a number written as ``text`` can stand for, ± half its last digit, times ``factor``:
    "0.0654" is [0.06535, 0.06545]; "4,000" is [3999.5, 4000.5]; a unicode minus reads as one."""
    clean = text.replace(",", "").replace("\u2009", "").replace("−", "-")
    digits = len(clean.partition(".")[2])
    value, half = float(clean), 0.5 * 10.0 ** -digits
    ends = sorted(((value - half) * factor, (value + half) * factor))
    return ends[0], ends[1]


def site_texts() -> dict[str, str]:
    """Where → text of everything a user reads: the README, the docs pages as the site shows them
    (the report's figures filled in), the config files and the package's and plugins' sources."""
    texts = {"README.md": (ROOT / "README.md").read_text(encoding="utf-8")}
    for page in sorted((ROOT / "docs").rglob("*.md")):
        if page.name == "report.md" or "decisions" in page.parts:
            continue
        texts[page.relative_to(ROOT).as_posix()] = report.fill_figures(page.read_text(encoding="utf-8"), NUMBERS)
    for path in [*sorted((ROOT / "conf").rglob("*.yaml")), *sorted((ROOT / "dsmv").rglob("*.py")),
                 *sorted((ROOT / "plugins").glob("*.py"))]:
        texts[path.relative_to(ROOT).as_posix()] = path.read_text(encoding="utf-8")
    return texts


def find_quotes(quantity: Quantity, texts: dict[str, str]) -> dict[str, list[Quote]]:
    """Each pattern of ``quantity`` → the quotes it finds in ``texts``."""
    found = {}
    for entry in quantity.patterns:
        pattern, factor = (entry, 1.0) if isinstance(entry, str) else entry
        spaced = re.compile(pattern.replace(" ", r"\s+"), re.MULTILINE)  # prose may wrap at any space
        quotes = []
        for where, text in texts.items():
            for match in spaced.finditer(text):
                line = text.count("\n", 0, match.start("v")) + 1
                quotes.append(Quote(f"{where}:{line}", match.group("v"), *read_number(match.group("v"), factor)))
        found[pattern] = quotes
    return found


def disagreement(quantity: Quantity, quotes: list[Quote]) -> str | None:
    """None when one value can be read as every quote and as the home's reference; else what disagrees."""
    low = max((q.low for q in quotes), default=-math.inf)
    high = min((q.high for q in quotes), default=math.inf)
    reference = quantity.reference() if quantity.reference else None
    if reference is not None:
        low, high = max(low, reference), min(high, reference)
    if low <= high + 1e-12 * max(1.0, abs(high)):
        return None
    lines = [f"{quantity.name} is quoted with different values (home: {quantity.home}"
             + (f", {reference:.6g})" if reference is not None else ")")]
    lines += [f"  {q.where}: {q.text}" + ("" if reference is None or q.low <= reference <= q.high
                                          else "  <- not the home's value") for q in quotes]
    return "\n".join(lines)


TEXTS = site_texts()


@pytest.mark.parametrize("quantity", QUANTITIES, ids=lambda q: q.name)
def test_every_quote_of_a_quantity_agrees_with_its_home_and_the_others(quantity):
    found = find_quotes(quantity, TEXTS)
    stale = [pattern for pattern, quotes in found.items() if not quotes]
    assert not stale, (f"{quantity.name}: no quote matches {stale}; a page was reworded, so the pattern "
                       "(tests/test_docs_figures.py) must follow it")
    quotes = [q for quotes in found.values() for q in quotes]
    assert len(quotes) + (quantity.reference is not None) >= 2, f"{quantity.name}: quoted once, nothing to compare"
    problem = disagreement(quantity, quotes)
    assert problem is None, problem


def test_two_pages_that_quote_different_values_fail():
    """The check can fail: two pages quoting the standard mesh's error as 1.3 % and 2.7 % disagree, and
    so do a page and its home; the same figure to fewer digits, or through a report template, agrees."""
    error = Quantity("an error (%)", "a page", (r"reads (?P<v>[\d.]+) % below",))
    one = {"README.md": "the default landing reads 1.3 % below its extrapolated value",
           "docs/guide/scenes.md": "the default landing\nreads 2.7 % below it"}
    problem = disagreement(error, [q for qs in find_quotes(error, one).values() for q in qs])
    assert problem is not None and "README.md:1: 1.3" in problem and "docs/guide/scenes.md:2: 2.7" in problem

    sinkage = Quantity("a sinkage (m)", "the report", (r"sinks (?P<v>[\d.]+) m",), reference=lambda: 0.065446)
    agreeing = {"a.md": "it sinks 0.065 m", "b.md": "it sinks 0.0654 m", "c.md": "it sinks 0.06545 m"}
    assert disagreement(sinkage, [q for qs in find_quotes(sinkage, agreeing).values() for q in qs]) is None
    stale = {"a.md": "it sinks 0.0654 m", "b.md": "it sinks 0.0603 m"}
    problem = disagreement(sinkage, [q for qs in find_quotes(sinkage, stale).values() for q in qs])
    assert problem is not None and "b.md:1: 0.0603  <- not the home's value" in problem

    numbers = {"checks": [{"key": "landing", "name": "a landing", "metric": "max_sinkage_m", "reference": 0.0663,
                           "outcomes": [{"cell_m": 0.02, "status": "ok", "value": 0.06545, "wall_s": 1.0}]}]}
    page = report.fill_figures("reads {{ report.landing.error@0.02:.1f }} % below", numbers)
    assert page == "reads −1.3 % below"
    signed = Quantity("an error (%)", "a page", (r"reads [−-]?(?P<v>[\d.]+) % below",))
    for readme, agrees in (("reads 1.3 % below", True), ("reads 2.7 % below", False)):
        quotes = find_quotes(signed, {"page.md": page, "README.md": readme})
        assert (disagreement(signed, [q for qs in quotes.values() for q in qs]) is None) == agrees


def test_a_number_stands_for_the_values_that_round_to_it():
    assert read_number("0.0654") == pytest.approx((0.06535, 0.06545))
    assert read_number("4,000") == (3999.5, 4000.5)
    assert read_number("−1.3") == pytest.approx((-1.35, -1.25))
    assert read_number("1131", 1 / 60) == pytest.approx((1130.5 / 60, 1131.5 / 60))
