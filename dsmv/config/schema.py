"""The base of every config schema: the field types (:data:`Number`, :data:`Count`), the frozen strict
model (:class:`Schema`) and the validation of one group into a one-line
:class:`~dsmv.errors.ConfigError` (:func:`_validate`). Plugins and solvers build their own schemas
on these."""

from __future__ import annotations

import difflib
from typing import Annotated, Any

from pydantic import BaseModel, BeforeValidator, ConfigDict, ValidationError

from dsmv.errors import ConfigError


def _reject_bool(value):
    # YAML `yes`/`true` must not pass as the number 1.
    if isinstance(value, bool):
        raise ValueError("must be a number, not a boolean")
    return value


Number = Annotated[float, BeforeValidator(_reject_bool)]
Count = Annotated[int, BeforeValidator(_reject_bool)]


class Schema(BaseModel):
    """Base of all config schemas: unknown keys, NaN and ±inf are errors; objects are frozen."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


def _validate(model: type[BaseModel], data: Any, prefix: str) -> BaseModel:
    """Validate one group; turn the first pydantic error into a one-line ConfigError."""
    if not isinstance(data, dict):
        raise ConfigError(prefix, data, "must be a config group (a mapping)")
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        err = exc.errors()[0]
        path = ".".join([prefix, *(str(p) for p in err["loc"])])
        value = err.get("input")
        if err["type"] == "missing":
            value = None
        message = err["msg"].replace("Input should be", "must be").replace("Value error, ", "")
        if err["type"] == "missing" and len(err["loc"]) == 1:  # say what the missing key is
            field = model.model_fields.get(str(err["loc"][0]))
            message = "missing" + (f": {field.description}" if field is not None and field.description else "")
        if err["type"] == "extra_forbidden" and len(err["loc"]) == 1:  # a typo: name the closest key
            close = difflib.get_close_matches(str(err["loc"][0]), list(model.model_fields), n=1, cutoff=0.6)
            if close:
                message += f"; did you mean {prefix}.{close[0]}?"
        raise ConfigError(path, value, message) from None
