"""A synthetic site measured on dsmv's CEL at known soil values.

    python -m dsmv.calibration.cel_site --out conf/site/cel site=synthetic_ccz
    python -m dsmv.calibration.cel_site --out /tmp/site --cells 6 --cycles 3 site=synthetic_ccz   # coarse

The site's test designs (its T-bar rates and depths, its cycles, its cones' masses and sample depths)
are run on the CEL in soil at ``calibrate.synthetic.truth``: each T-bar rate one push through its
profile (the rows from where the push is steady on), each cyclic test one cyclic push, each cone one
drop (:mod:`dsmv.calibration.cel_tests`). Each test's CSV is written without scatter; a site that
names them with ``synthetic.values: files`` adds its scatter to them. Calibrated back by the fast
models, they say how well those models recover a truth that is not their own.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from dsmv.calibration.cel_tests import measure
from dsmv.calibration.data import write_test


def main(argv: list[str] | None = None) -> None:
    from dsmv.calibration.run import _flat, check_config
    from dsmv.config.tree import compose

    parser = argparse.ArgumentParser(prog="python -m dsmv.calibration.cel_site", description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True, help="folder for the tests' CSV files")
    parser.add_argument("--cells", type=int, default=10, help="core cells across the T-bar (default 10)")
    parser.add_argument("--cycles", type=int, default=None, help="cycles of a cyclic test (default: its own)")
    parser.add_argument("--tests", nargs="+", default=None, help="only these tests (their files' stems)")
    parser.add_argument("--runs", default="runs/cel_site", help="folder for the CEL runs (default runs/cel_site)")
    parser.add_argument("--set", nargs="+", default=[], help="overrides for every CEL run (solver.initial_travel_m=0.8)")
    parser.add_argument("--pushes", type=int, default=0, help="a profile as this many short pushes (default: one push)")
    parser.add_argument("overrides", nargs="*", default=["site=synthetic_ccz"], help="dsmv-calibrate overrides")
    args = parser.parse_args(argv)
    settings, problem = check_config(compose("calibrate", ["tracking=disabled", *args.overrides]))
    if settings.synthetic is None:
        raise SystemExit("cel_site: the site must name its truth (site=synthetic_ccz, or calibrate.synthetic.truth)")
    truth = _flat(settings.synthetic.truth)
    soil = problem.soil_at([float(truth.get(k, s)) for k, s in zip(problem.keys, problem.start)])
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    said = ", ".join(f"{k} = {v:g}" for k, v in truth.items())
    tests = [t for t in problem.tests if args.tests is None or t.name in args.tests]
    unknown = set(args.tests or ()) - {t.name for t in problem.tests}
    if unknown:
        raise SystemExit(f"cel_site: no test {', '.join(sorted(unknown))}; the site's: "
                         + ", ".join(t.name for t in problem.tests))
    for test in tests:
        measured = measure(test, soil, args.cells, Path(args.runs), args.cycles, tuple(args.set), args.pushes)
        path = write_test(out / f"{test.name}.csv", measured)
        path.write_text(f"# {test.name}: measured on dsmv's CEL ({args.cells} cells across the T-bar; the cone on its "
                        f"own mesh) at {said}, without scatter:\n# python -m dsmv.calibration.cel_site --out {args.out} "
                        f"--cells {args.cells}{f' --cycles {args.cycles}' if args.cycles else ''}"
                        f"{' --set ' + ' '.join(args.set) if args.set else ''}"
                        f"{' --tests ' + test.name if args.tests else ''}{f' --pushes {args.pushes}' if args.pushes else ''} -- "
                        f"{' '.join(args.overrides)}\n" + path.read_text())
    print(f"cel_site: {len(tests)} tests written to {out} in {time.perf_counter() - started:.0f} s")


if __name__ == "__main__":
    try:
        main()
    except KeyboardInterrupt as stop:  # the tests written before it are kept
        import sys

        from dsmv.results import EXIT_CODES

        print(f"cel_site: interrupted: {stop}", file=sys.stderr)
        sys.exit(EXIT_CODES["interrupted"])
