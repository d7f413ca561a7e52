"""Site-test data as ``dsmv-calibrate`` reads it: CSV files whose header names each column's unit.

``kind: tbar`` (a T-bar penetration profile, one or more rates, optionally cyclic):
``depth_m|depth_cm|depth_mm`` (the bar's depth), ``resistance_pa|resistance_kpa`` (net penetration
resistance), ``velocity_m_s|velocity_mm_s``, and optionally ``cycle`` (1, 2, …: the resistance in that
cycle's penetration stroke; 1 when absent). Within a cycle the depths increase row by row.

``kind: fall_cone``: ``mass_kg|mass_g``, ``penetration_m|penetration_mm``, and optionally
``sample_depth_m|sample_depth_cm`` (where the sample was taken; 0 when absent).

A mistake in a file is one line naming the file, the column or row, and what is allowed (exit 2).
"""

from __future__ import annotations

import csv
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from dsmv.errors import ConfigError

#: quantity → {column name: factor to SI}
UNITS = {
    "depth": {"depth_m": 1.0, "depth_cm": 0.01, "depth_mm": 0.001},
    "resistance": {"resistance_pa": 1.0, "resistance_kpa": 1000.0},
    "velocity": {"velocity_m_s": 1.0, "velocity_mm_s": 0.001},
    "cycle": {"cycle": 1.0},
    "mass": {"mass_kg": 1.0, "mass_g": 0.001},
    "penetration": {"penetration_m": 1.0, "penetration_mm": 0.001},
    "sample_depth": {"sample_depth_m": 1.0, "sample_depth_cm": 0.01},
}
#: per kind: the quantities a file must hold, and those it may (with their value when absent)
KINDS = {
    "tbar": (("depth", "resistance", "velocity"), {"cycle": 1.0}),
    "fall_cone": (("mass", "penetration"), {"sample_depth": 0.0}),
}
#: what each kind's model returns and the data compare with
MEASURED = {"tbar": "resistance", "fall_cone": "penetration"}


@dataclass(frozen=True)
class SiteTest:
    """One test file's rows in SI units, by quantity, and the test's settings."""

    kind: str
    name: str          # the file's stem: how the summary and the figure name it
    columns: dict[str, np.ndarray]
    diameter_m: float = 0.04        # tbar: the bar's diameter (m)
    apex_angle_deg: float = 30.0    # fall_cone: the cone's apex angle (degrees)

    @property
    def measured(self) -> np.ndarray:
        return self.columns[MEASURED[self.kind]]

    def __len__(self) -> int:
        return len(self.measured)

    def rows(self, which: np.ndarray) -> SiteTest:
        """The test with only the rows ``which`` selects (a mask or indices)."""
        return replace(self, columns={k: np.asarray(v)[which] for k, v in self.columns.items()})


def _quantity(column: str) -> str | None:
    """The quantity a column names, units aside (``resistance_psi`` → ``resistance``)."""
    for quantity in sorted(UNITS, key=len, reverse=True):
        if column == quantity or column.startswith(quantity + "_"):
            return quantity
    return None


def read_test(kind: str, path: str | Path, where: str, **settings) -> SiteTest:
    """The test in ``path`` (``where`` names its config key in errors), checked."""
    if kind not in KINDS:
        raise ConfigError(f"{where}.kind", kind, f"must be one of {', '.join(KINDS)}")
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"{where}.path", str(path), "no such file")
    with path.open(newline="") as handle:
        rows = list(csv.reader(line for line in handle if line.strip() and not line.lstrip().startswith("#")))
    if len(rows) < 2:
        raise ConfigError(f"{where}.path", str(path), "holds no rows under its header")
    header = [h.strip().lower() for h in rows[0]]
    needed, optional = KINDS[kind]
    found: dict[str, int] = {}
    for i, column in enumerate(header):
        quantity = _quantity(column)
        if quantity not in (*needed, *optional):
            continue
        if column not in UNITS[quantity]:
            raise ConfigError(f"{where}.path", f"{path.name}: column {column}",
                              f"its unit is not understood; use {' | '.join(UNITS[quantity])}")
        found[quantity] = i
    missing = [q for q in needed if q not in found]
    if missing:
        raise ConfigError(f"{where}.path", f"{path.name}: columns {', '.join(header)}", f"a {kind} test needs "
                          + ", ".join(f"{q} ({' | '.join(UNITS[q])})" for q in missing))
    columns = {}
    for quantity, default in [*((q, None) for q in needed), *optional.items()]:
        if quantity not in found:
            columns[quantity] = np.full(len(rows) - 1, default)
            continue
        i, name = found[quantity], header[found[quantity]]
        try:
            values = np.array([float(r[i]) for r in rows[1:]])
        except (ValueError, IndexError):
            raise ConfigError(f"{where}.path", f"{path.name}: column {name}", "a row holds no number there") from None
        may_be_zero = quantity in ("depth", "sample_depth")
        bad = ~np.isfinite(values) | ((values < 0) if may_be_zero else (values <= 0))
        if bad.any():
            row = int(np.nonzero(bad)[0][0]) + 2  # the header is row 1
            raise ConfigError(f"{where}.path", f"{path.name} row {row}: {name} {values[bad][0]:g}",
                              f"must be {'≥ 0' if may_be_zero else '> 0'}")
        columns[quantity] = values * UNITS[quantity][name]
    if kind == "tbar":
        cycles = columns["cycle"]
        if np.any(cycles != np.round(cycles)):
            raise ConfigError(f"{where}.path", f"{path.name}: cycle", "cycles are whole numbers 1, 2, …")
        for cycle in np.unique(cycles):
            depth = columns["depth"][cycles == cycle]
            if np.any(np.diff(depth) <= 0):
                raise ConfigError(f"{where}.path", f"{path.name}: cycle {cycle:g}",
                                  "depths must increase row by row within a cycle (sort the rows)")
    return SiteTest(kind, path.stem, columns, **settings)


def write_test(path: Path, test: SiteTest) -> Path:
    """``test`` as a CSV in SI units that :func:`read_test` reads back."""
    quantities = [*KINDS[test.kind][0], *KINDS[test.kind][1]]
    names = [next(iter(UNITS[q])) for q in quantities]
    path.write_text(",".join(names) + "\n" + "\n".join(
        ",".join(f"{test.columns[q][k]:.10g}" for q in quantities) for k in range(len(test))) + "\n")
    return path


__all__ = ["SiteTest", "read_test", "write_test", "KINDS", "UNITS", "MEASURED"]
