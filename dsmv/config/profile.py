"""A soil's intact strength against depth as data: ``soil.profile``.

A table of (depth, su) points, inline in YAML (``[[0, 3450], [0.114, 6890]]``, m and Pa) or a CSV file
whose header names each column's unit (``depth_m`` or ``depth_cm``; ``su_pa`` or ``su_kpa``). Between
points su is linear in depth; below the last point it stays at the last value; above the first it
follows the first segment (soil heaved above the mudline). Two points at the same depth make a jump
(a layer boundary). Without a table the profile is the straight line su0 + ks·z, one segment.

A table may also layer the soil law's values: further columns named by their soil keys
(``sensitivity``, ``xi95``, ``rate.eta``, ``rate.n``, ``rate.gamma_dot_ref``, ``rate.mu``,
``params.<name>``), in a CSV or inline as columns (``{depth_m: [...], su_pa: [...], sensitivity: [...]}``).
A row's values hold from its depth down to the next row's (the first reaching up, the last down): a
depth given twice with different values is a boundary between layers (:class:`LawLayers`). A
``density_kg_m3`` column layers the buoyant density the same way (:class:`DensityLayers`).

The solvers read the profile as segments (:class:`StrengthSegments`): each from its top depth down,
su = intercept + slope·z. A straight line is one segment whose intercept and slope are su0 and ks
exactly, so a tabulated straight line with exact slopes gives the same answers to the bit.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import NamedTuple

import numpy as np

from dsmv.config.location import data_path
from dsmv.errors import ConfigError

#: the units a CSV column may name, as factors to m and Pa
DEPTH_UNITS = {"depth_m": 1.0, "depth_cm": 0.01, "depth_mm": 0.001}
STRENGTH_UNITS = {"su_pa": 1.0, "su_kpa": 1000.0}
KEY = "soil.profile"
#: the soil keys a table's further columns may layer (and any ``params.<name>`` of the law's own)
LAW_KEYS = ("sensitivity", "xi95", "rate.eta", "rate.n", "rate.gamma_dot_ref", "rate.mu")
#: the soil key of a table's density column (kg/m³)
DENSITY_KEY = "density_kg_m3"
LAYERED = f"{', '.join(LAW_KEYS)}, {DENSITY_KEY} or params.<name>"


class StrengthSegments(NamedTuple):
    """The profile as the kernels read it: per segment its top depth (m; the first −∞), intercept (Pa)
    and slope (Pa/m), su = intercept + slope·z from the segment's top down to the next one's."""

    depth: np.ndarray
    intercept: np.ndarray
    slope: np.ndarray

    def su(self, depth_m) -> np.ndarray:
        """su_intact at the depths given (Pa)."""
        z = np.asarray(depth_m, dtype=float)
        k = np.searchsorted(self.depth, z, side="right") - 1
        return self.intercept[k] + self.slope[k] * z

    def gradient(self, depth_m) -> np.ndarray:
        """dsu/dz at the depths given (Pa/m): the slope of the segment below each (0 below the last point)."""
        z = np.asarray(depth_m, dtype=float)
        return self.slope[np.searchsorted(self.depth, z, side="right") - 1]

    @property
    def straight(self) -> bool:
        """Whether the profile is one straight line su0 + ks·z down to its last point (a table of points
        on one line; below the last, a table stays constant)."""
        lines = set(zip(self.intercept[:-1], self.slope[:-1])) if len(self.depth) > 1 else {0}
        return len(lines) == 1


def refuse_a_bent_profile(soil, model: str) -> None:
    """The analytic models read su0 + ks·z: a table that is not one straight line is refused, in one line."""
    if soil.bent_strength is not None:
        raise ConfigError(KEY, "a table", f"{model} takes a straight-line strength su0 + ks·z; a bent or layered "
                          "profile runs in solver=cel2d or cel3d")


def refuse_a_layered_law(soil, model: str) -> None:
    """A model that takes one set of the law's values refuses a table that layers them, in one line."""
    if (layers := soil.law_layers) is not None:
        raise ConfigError(KEY, f"a table layering {', '.join(layers.values)}", f"{model} takes one set of the soil "
                          "law's values; a soil whose law changes with depth runs in solver=cel2d or cel3d")


def refuse_a_layered_density(soil, model: str) -> None:
    """A model that takes one density refuses a table that layers it, in one line."""
    if soil.density_layers is not None:
        raise ConfigError(KEY, f"a table layering {DENSITY_KEY}", f"{model} takes one density; a soil whose "
                          "density changes with depth runs in solver=cel2d, cel3d, analytic_dynamic or "
                          "analytic_dynamic_3d")


def straight_line(su0_pa: float, ks_pa_per_m: float) -> StrengthSegments:
    """su0 + ks·z as one segment."""
    return StrengthSegments(np.array([-math.inf]), np.array([float(su0_pa)]), np.array([float(ks_pa_per_m)]))


class LawLayers(NamedTuple):
    """The soil law's values by layer: each layer's top depth (m; the first −∞) and, per soil key the table
    layers, its value in each layer."""

    top: np.ndarray
    values: dict[str, np.ndarray]

    def at(self, depth_m: float) -> int:
        """The layer holding ``depth_m``."""
        return int(np.searchsorted(self.top, depth_m, side="right") - 1)


class DensityLayers(NamedTuple):
    """The buoyant density by layer, as the solvers read it: each layer's top depth (m; the first −∞), its
    density over the lightest layer's (``ratio``, ≥ 1) and the intercept of the weighing depth there.

    The weighing depth of a depth z is the depth of soil of the lightest density as heavy as the column
    above z (m): w(z) = ∫₀^z ρ/ρ_lightest dz' = intercept + ratio·z in z's layer, so the geostatic vertical
    stress is −ρ_lightest·g·w(z)."""

    top: np.ndarray
    ratio: np.ndarray
    intercept: np.ndarray
    lightest_kg_m3: float

    @classmethod
    def of(cls, layers: LawLayers) -> "DensityLayers":
        density = layers.values[DENSITY_KEY]
        lightest = float(density.min())
        ratio = density / lightest
        intercept = np.zeros(len(ratio))
        for k in range(1, len(ratio)):  # w is continuous at each top: the layer above's w there
            intercept[k] = intercept[k - 1] + (ratio[k - 1] - ratio[k]) * layers.top[k]
        return cls(layers.top, ratio, intercept, lightest)

    def weighing_depth(self, depth_m) -> np.ndarray:
        """w(z) at the depths given (m)."""
        z = np.asarray(depth_m, dtype=float)
        k = np.searchsorted(self.top, z, side="right") - 1
        return self.intercept[k] + self.ratio[k] * z

    def ratio_at(self, depth_m) -> np.ndarray:
        """ρ/ρ_lightest at the depths given."""
        return self.ratio[np.searchsorted(self.top, np.asarray(depth_m, dtype=float), side="right") - 1]


def weighed(density_kg_m3, layers: DensityLayers | None, depth_m):
    """The column of soil above ``depth_m`` as a buoyant density (kg/m³) times a height (m) that weighs it:
    ``density_kg_m3`` and the depth, or a layered density's lightest and its weighing depth there."""
    if layers is None:
        return density_kg_m3, depth_m
    return layers.lightest_kg_m3, layers.weighing_depth(depth_m)


def read_points(value) -> np.ndarray:
    """The profile's points, (n, 2): depth (m) and su (Pa), from an inline table or a CSV path
    (:func:`dsmv.config.location.data_path`), checked: depths in order (a repeated depth is a jump), none
    negative, strengths > 0."""
    return read_table(value)[0]


def law_layers(value, which: str = "law") -> LawLayers | None:
    """The layers that the table's further columns give: of the law's soil keys (``which`` "law"), of the
    density ("density") or of both ("all"); None without such columns."""
    points, columns = read_table(value)
    keep = {"law": _law_key, "density": lambda k: k == DENSITY_KEY, "all": _layer_key}[which]
    columns = {k: v for k, v in columns.items() if keep(k)}
    if not columns:
        return None
    depth = points[:, 0]
    last = np.r_[depth[1:] != depth[:-1], True]     # of rows at one depth, the last holds from there down
    top = depth[last].copy()
    top[0] = -math.inf
    return LawLayers(top, {k: v[last] for k, v in columns.items()})


def read_table(value) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The profile's points (:func:`read_points`) and its law columns by soil key, each a value per row."""
    columns: dict[str, np.ndarray] = {}
    if isinstance(value, (str, Path)):
        points, columns = _read_csv(data_path(value))
    elif isinstance(value, dict):
        points, columns = _read_columns(value)
    else:
        try:
            points = np.array(value, dtype=float).reshape(-1, 2)
        except (TypeError, ValueError):
            raise ConfigError(KEY, value, "a table of [depth_m, su_pa] rows, its columns {depth_m: [...], su_pa: "
                              "[...], ...} or the path of a CSV file") from None
    if len(points) == 0:
        raise ConfigError(KEY, [], "needs at least one [depth_m, su_pa] row")
    depth, su = points.T
    if not np.isfinite(points).all():
        raise ConfigError(KEY, points.tolist(), "holds a value that is not a number")
    if (depth < 0).any():
        raise ConfigError(KEY, float(depth[depth < 0][0]), "depths are below the mudline: ≥ 0 (m)")
    if (np.diff(depth) < 0).any():
        k = int(np.nonzero(np.diff(depth) < 0)[0][0])
        raise ConfigError(KEY, f"{depth[k]:g} m then {depth[k + 1]:g} m", "depths must not decrease (sort the rows; "
                          "a depth given twice is a jump)")
    if (su <= 0).any():
        raise ConfigError(KEY, float(su[su <= 0][0]), "strengths must be > 0 (Pa)")
    for key, values in columns.items():
        if not np.isfinite(values).all():
            raise ConfigError(KEY, f"{key} {values.tolist()}", "holds a value that is not a number")
    return points, columns


def _law_key(name: str) -> bool:
    return name in LAW_KEYS or (name.startswith("params.") and len(name) > len("params."))


def _layer_key(name: str) -> bool:
    return _law_key(name) or name == DENSITY_KEY


def _read_columns(table: dict) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """An inline table given by columns: depth and strength (with their units) and law columns."""
    names = [str(k).strip().lower() for k in table]
    depth_col = next((c for c in names if c in DEPTH_UNITS), None)
    su_col = next((c for c in names if c in STRENGTH_UNITS), None)
    if depth_col is None or su_col is None:
        raise ConfigError(KEY, f"columns {', '.join(names)}", "needs a depth column "
                          f"({' | '.join(DEPTH_UNITS)}) and a strength column ({' | '.join(STRENGTH_UNITS)})")
    columns = {}
    for name, raw in zip(names, table.values()):
        if name not in (depth_col, su_col) and not _layer_key(name):
            raise ConfigError(KEY, f"column {name}", f"not a soil key the table layers: {LAYERED}")
        try:
            columns[name] = np.array(raw, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            raise ConfigError(KEY, f"column {name}", "must be a list of numbers") from None
    lengths = {len(v) for v in columns.values()}
    if len(lengths) != 1:
        raise ConfigError(KEY, f"columns of {sorted(lengths)} values", "every column needs one value per row")
    points = np.column_stack([columns.pop(depth_col) * DEPTH_UNITS[depth_col], columns.pop(su_col) * STRENGTH_UNITS[su_col]])
    return points, columns


def _read_csv(path: Path) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    if not path.is_file():
        raise ConfigError(KEY, str(path), "no such file")
    with path.open(newline="") as handle:
        rows = list(csv.reader(line for line in handle if line.strip() and not line.lstrip().startswith("#")))
    if not rows:
        raise ConfigError(KEY, str(path), "the file is empty")
    header = [h.strip().lower() for h in rows[0]]
    depth_col = next((c for c in header if c in DEPTH_UNITS), None)
    su_col = next((c for c in header if c in STRENGTH_UNITS), None)
    if depth_col is None or su_col is None:
        raise ConfigError(KEY, f"{path.name}: columns {', '.join(header)}", "needs a depth column "
                          f"({' | '.join(DEPTH_UNITS)}) and a strength column ({' | '.join(STRENGTH_UNITS)})")
    i, j = header.index(depth_col), header.index(su_col)
    try:
        points = [(float(r[i]) * DEPTH_UNITS[depth_col], float(r[j]) * STRENGTH_UNITS[su_col]) for r in rows[1:]]
    except (ValueError, IndexError):
        raise ConfigError(KEY, str(path), f"a row of {depth_col}, {su_col} is not a pair of numbers") from None
    columns = {}
    for k, name in enumerate(header):
        if k in (i, j):
            continue
        if not _layer_key(name):
            raise ConfigError(KEY, f"{path.name}: column {name}", f"not a soil key the table layers: {LAYERED}")
        try:
            columns[name] = np.array([float(r[k]) for r in rows[1:]])
        except (ValueError, IndexError):
            raise ConfigError(KEY, f"{path.name}: column {name}", "a row's value is not a number") from None
    return np.array(points, dtype=float).reshape(-1, 2), columns


def segments(points: np.ndarray) -> StrengthSegments:
    """The segments through the points: one per pair of points at different depths (the first reaching
    up to −∞), then the last point's strength below it; a repeated depth is a jump."""
    depth, su = points.T
    tops, intercepts, slopes = [], [], []
    for k in range(len(points) - 1):
        if depth[k + 1] == depth[k]:
            continue
        slope = (su[k + 1] - su[k]) / (depth[k + 1] - depth[k])
        tops.append(depth[k])
        intercepts.append(su[k] - slope * depth[k])
        slopes.append(slope)
    tops.append(depth[-1])
    intercepts.append(su[-1])
    slopes.append(0.0)
    tops[0] = -math.inf
    return StrengthSegments(np.array(tops), np.array(intercepts), np.array(slopes))
