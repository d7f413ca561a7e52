"""The number a ``dsmv`` job returns: what a sweeper that optimises (``hydra/sweeper=optuna``) minimises.

Every job returns a float, whatever its status (config ``objective``):

- ``objective.name: contact_area_m2`` — the track's contact area B·L (m²), plus
  ``penalty_m2_per_m`` for every metre the run sinks beyond ``sinkage_limit_m``: the smallest
  track that keeps the vehicle above the limit. (Minimising the sinkage alone drives B and L to
  their upper bounds; minimising the area alone to their lower ones.) The default penalty,
  100 m² per metre, makes 1 cm too deep cost 1 m², more than the area a step of either
  dimension saves over the design ranges of the study;
- any metric of result.json (``max_sinkage_m``, the default; ``nc_at_0p1B``; ...) as it is.

A run that did not end ``ok`` (bearing failure, unstable, failed, interrupted) returns
``not_ok_value``: the sweeper sees it as worse than any answer.
"""

from __future__ import annotations

import math
import sys
from typing import Any, Optional

from pydantic import Field

from dsmv.config.schema import Number, Schema, _validate
from dsmv.errors import ConfigError

#: the objective that is not a metric of result.json but the scene's area with its penalty
CONTACT_AREA = "contact_area_m2"


class ObjectiveConfig(Schema):
    """Config ``objective``."""

    name: str = Field("max_sinkage_m", description="contact_area_m2, or a metric of result.json")
    sinkage_limit_m: Optional[Number] = Field(None, gt=0, description="contact_area_m2: the sinkage allowed (m)")
    penalty_m2_per_m: Number = Field(100.0, ge=0, description="contact_area_m2: added per metre beyond the limit (m²/m)")
    not_ok_value: Number = Field(1.0e3, description="what a run that did not end ok returns")


def objective_config(container: dict[str, Any]) -> ObjectiveConfig:
    """The validated ``objective`` of a composed config (its defaults when absent)."""
    config = _validate(ObjectiveConfig, container.get("objective") or {}, "objective")
    if config.name == CONTACT_AREA and config.sinkage_limit_m is None:
        raise ConfigError("objective.sinkage_limit_m", None, f"objective.name = {CONTACT_AREA} needs the sinkage allowed (m)")
    return config


def objective_value(config: ObjectiveConfig, result: dict, geometry: dict) -> float:
    """The job's return value from its result.json content (``status``, ``metrics``) and geometry."""
    if result.get("status") != "ok":
        return float(config.not_ok_value)
    metrics = result.get("metrics", {})
    if config.name != CONTACT_AREA:
        value = metrics.get(config.name)
        if value is None or not math.isfinite(value):
            print(f"dsmv: objective.name = {config.name!r} is not a finite metric of this run: it returns "
                  f"objective.not_ok_value ({config.not_ok_value})", file=sys.stderr)
            return float(config.not_ok_value)
        return float(value)
    area = float(geometry["width_m"]) * float(geometry["contact_length_m"])
    excess = max(0.0, float(metrics["max_sinkage_m"]) - config.sinkage_limit_m)
    return area + config.penalty_m2_per_m * excess
