"""How often a synthetic calibration's intervals hold the true values, over noise draws.

    python -m dsmv.calibration.coverage                       # site=synthetic_ccz, draws 2…21, 200 refits
    python -m dsmv.calibration.coverage --draws 2:6 --bootstrap 100 site=synthetic_ccz calibrate.confidence=0.8

Each draw regenerates the site's data with ``calibrate.synthetic.seed`` set to it and calibrates them;
the table counts, per parameter, the intervals that held the true value, the draws that resolved it
and, of those, the ones within 10 % of it. A calibrated 90 % interval holds it in 90 % of draws; with
20 draws the count is Binomial(20, 0.9): 16–20 in 96 % of studies.
"""

from __future__ import annotations

import argparse
import time


from dsmv.calibration.fit import calibrate
from dsmv.calibration.run import _flat, check_config


def study(overrides: list[str], draws: range, bootstrap: int) -> dict[str, dict[str, int]]:
    """Per fitted key: ``inside`` (intervals holding the truth), ``resolved`` and ``close`` (resolved and
    within 10 %), over ``draws``; printed draw by draw."""
    from dsmv.config.tree import compose

    counts: dict[str, dict[str, int]] = {}
    for draw in draws:
        started = time.perf_counter()
        settings, problem = check_config(compose("calibrate", ["tracking=disabled", *overrides,
                                                               f"calibrate.synthetic.seed={draw}"]))
        if settings.synthetic is None:
            raise SystemExit("coverage: the site must be synthetic (site=synthetic_ccz, or calibrate.synthetic)")
        cal = calibrate(problem, bootstrap, settings.confidence, settings.resolved_width, draw)
        truth = _flat(settings.synthetic.truth)
        for key, best, low, high, resolved in zip(cal.keys, cal.best, cal.lower, cal.upper, cal.resolved):
            if key not in truth:
                continue
            count = counts.setdefault(key, {"inside": 0, "resolved": 0, "close": 0})
            count["inside"] += int(low <= truth[key] <= high)
            count["resolved"] += int(resolved)
            count["close"] += int(resolved and abs(best / truth[key] - 1) <= 0.10)
        print(f"draw {draw}: {time.perf_counter() - started:.0f} s", flush=True)
    return counts


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m dsmv.calibration.coverage", description=__doc__.splitlines()[0])
    parser.add_argument("--draws", default="2:22", help="noise seeds start:stop (default 2:22)")
    parser.add_argument("--bootstrap", type=int, default=200, help="refits per calibration (default 200)")
    parser.add_argument("overrides", nargs="*", default=["site=synthetic_ccz"], help="dsmv-calibrate overrides")
    args = parser.parse_args(argv)
    start, _, stop = args.draws.partition(":")
    draws = range(int(start), int(stop))
    counts = study(args.overrides, draws, args.bootstrap)
    n = len(draws)
    print(f"\n{n} draws, {args.bootstrap} refits each: intervals holding the truth, draws resolving it, "
          "resolved within 10 %")
    for key, count in counts.items():
        print(f"  {key:<22} {count['inside']:>3}/{n}  {count['resolved']:>3}/{n}  {count['close']:>3}/{count['resolved']}")
    total = sum(c["inside"] for c in counts.values())
    print(f"  all: {total}/{n * len(counts)} ({total / max(n * len(counts), 1):.0%})")


if __name__ == "__main__":
    main()
