"""``dsmv-plugins new soil-law|surrogate NAME``: a complete plugin package that installs and passes as written.

A soil-law package holds the law (linear softening with a declared parameter, to edit), a soil
profile of its own that Hydra finds through the ``dsmv.configs`` entry point (``soil=NAME_clay``),
and tests that call :mod:`dsmv.testing`: ``pip install -e NAME-law``, then ``dsmv soil=NAME_clay``,
``dsmv soil.law=NAME``, ``pytest NAME-law/tests``. A surrogate package holds the plugin
(extremely randomised trees, to edit), its ``surrogate`` option (``dsmv-train surrogate=NAME``)
and its tests.
"""

from __future__ import annotations

import keyword
import re
from pathlib import Path

from dsmv.errors import ConfigError

PYPROJECT = '''[build-system]
requires = ["setuptools>=77"]
build-backend = "setuptools.build_meta"

[project]
name = "{dist}"
version = "0.1.0"
description = "The {name} {what} for dsmv"
requires-python = ">=3.11"
dependencies = [{dependencies}]

[project.optional-dependencies]
test = ["pytest"]

# the plugin, by the name its config uses ({selects})
[project.entry-points."{group}"]
{name} = "{package}.{module}:{cls}"

# the package's config groups, found by Hydra beside dsmv's own ({option})
[project.entry-points."dsmv.configs"]
{name} = "{package}.conf"

[tool.setuptools]
packages = ["{package}", "{package}.conf", "{package}.conf.{config_group}"]

[tool.setuptools.package-data]
"*" = ["*.yaml"]
'''

LAW = '''"""The {name} soil law: linear softening, su = su_intact(z0)·max(1 − a·ξ, 1/St).

Edit ``factor`` and its NumPy twin ``strength_factor`` together; declare every parameter you read
from ``soil.params`` in ``Parameters`` (unit in the description, range as bounds, a default).
"""

import numpy as np
from pydantic import Field

from dsmv.soil_law import LawParameters, SoilLaw


class Parameters(LawParameters):
    """The keys of ``soil.params`` this law reads."""

    slope: float = Field(0.05, gt=0, le=1,
                         description="a (-): strength lost per unit of accumulated plastic shear strain")


class {cls}(SoilLaw):
    name = "{name}"
    parameters_model = Parameters

    @property
    def softens(self) -> bool:
        """Whether the strength falls with ξ for this soil (if not, the solvers skip the law)."""
        return self.soil.sensitivity > 1.0

    def parameters(self) -> np.ndarray:
        """Up to 8 floats, in the order ``factor`` takes them after (xi, gamma_dot, s0, s1)."""
        return np.array([self.params.slope, 1.0 / self.soil.sensitivity])

    @staticmethod
    def factor(xi, gamma_dot, s0, s1, slope, floor, p2, p3, p4, p5, p6, p7):
        """su/su_intact at one material point: plain Python and math (dsmv compiles it with Numba)."""
        return max(1.0 - slope * xi, floor)

    def strength_factor(self, xi, gamma_dot_per_s, *state):
        """The same with NumPy arrays: the twin the tests hold ``factor`` to."""
        xi, _ = np.broadcast_arrays(np.asarray(xi, dtype=float), np.asarray(gamma_dot_per_s, dtype=float))
        return np.maximum(1.0 - self.params.slope * xi, 1.0 / self.soil.sensitivity)
'''

PROFILE = '''# A soil profile that runs the {name} law: dsmv soil={name}_clay
name: {name}_clay
law: {name}
su0_pa: 5000.0             # intact undrained shear strength at the mudline (Pa)
ks_pa_per_m: 1500.0        # strength gradient with depth (Pa/m)
sensitivity: 3.0           # St = su_intact / su_remoulded (-)
xi95: 25.0                 # accumulated plastic shear strain for 95 % softening (-); unused by {name}
rate:
  law: power
  eta: 0.0                 # {name} has no rate effect
  n: 0.2
  gamma_dot_ref: 3.0e-6
  mu: 0.0
density_kg_m3: 600.0       # submerged (buoyant) density (kg/m3)
youngs_modulus_pa: 2.5e6   # E = 500 su0 (Pa)
poisson_ratio: 0.49        # (-)
params:
  slope: 0.05              # soil.params.slope (-): see {package}/law.py
'''

TESTS = '''"""The {name} law against dsmv's plugin contract (dsmv.testing) and its own closed form."""

import pytest

from dsmv.testing import check_kernel_matches_twin, check_limits, check_monotone, check_simple_shear, make_law


@pytest.mark.parametrize("slope", [0.01, 0.1, 1.0])
def test_the_law_keeps_the_plugin_contract(slope):
    law = make_law("{name}", "soil.sensitivity=4", f"++soil.params.slope={{slope}}")
    check_kernel_matches_twin(law)
    check_limits(law)
    check_monotone(law)
    check_simple_shear(law)


def test_the_closed_form():
    law = make_law("{name}", "soil.sensitivity=4", "++soil.params.slope=0.1")
    assert law.strength_factor(5.0, 1.0) == pytest.approx(0.5)      # 1 − 0.1·5
    assert law.strength_factor(100.0, 1.0) == pytest.approx(0.25)   # remoulded: 1/St


def test_its_profile_selects_it():
    from dsmv.testing import compose_scene

    scene = compose_scene("soil={name}_clay")
    assert scene.soil.law == "{name}" and scene.soil.params["slope"] == 0.05
'''

README = '''# {dist}

The `{name}` soil law for dsmv, and a soil profile that uses it.

```bash
pip install -e {dist}                 # into dsmv's environment
dsmv-plugins --check                  # {name} is listed and loads
dsmv soil={name}_clay                 # the profile
dsmv soil.law={name} ++soil.params.slope=0.1
pytest {dist}/tests
```
'''


SURROGATE = '''"""The {name} surrogate: extremely randomised trees (scikit-learn), a bagged cousin of the random forest.

Edit ``make``: it returns an unfitted regressor with fit(X, y), predict(X) and feature_importances_.
"""

from dsmv.surrogate.base import Surrogate


class {cls}(Surrogate):
    name = "{name}"
    label = "extremely randomised trees"  # what the model is, in words: figures name it
    flavor = "mlflow.sklearn"
    # MLflow saves scikit-learn models with skops, which refuses types it cannot vouch for: the trees
    # are fitted in this process, so their node storage is trusted
    log_model_kwargs = {{"skops_trusted_types": ["sklearn.tree._tree.Tree"]}}

    def make(self, **params):
        from sklearn.ensemble import ExtraTreesRegressor  # heavy imports inside the call

        return ExtraTreesRegressor(random_state=self.seed, n_jobs=self.n_jobs, **params)
'''

SURROGATE_OPTION = '''# The {name} surrogate: dsmv-train surrogate={name}
name: {name}
registered_model: dsmv-sinkage-{name}
params: {{}}                 # fixed hyper-parameters, passed to every fit
grid:                      # grid-searched hyper-parameters
  n_estimators: [100, 300]
  max_depth: [9, null]
grid_cv_folds: 5
'''

SURROGATE_TESTS = '''"""The {name} surrogate against dsmv's plugin contract (dsmv.testing)."""

from dsmv.testing import check_surrogate, compose_config


def test_the_surrogate_keeps_the_plugin_contract():
    check_surrogate("{name}", n_estimators=20)


def test_its_option_selects_it():
    cfg = compose_config("train", "surrogate={name}")
    assert cfg.surrogate.name == "{name}"
'''


def _identifier(name: str) -> str:
    if not re.fullmatch(r"[a-z][a-z0-9_]*", name) or keyword.iskeyword(name):
        raise ConfigError("NAME", name, "must be a lower-case Python identifier (letters, digits, _), e.g. my_clay")
    return name


#: what ``new`` writes: kind → (package suffix, class suffix)
KINDS = {"soil-law": ("law", "Law"), "surrogate": ("surrogate", "Surrogate")}


def package_files(kind: str, name: str) -> dict[str, str]:
    """The files of the ``kind`` package for plugin ``name`` (a Python identifier), by relative path."""
    suffix, cls_suffix = KINDS[kind]
    package, dist = f"{_identifier(name)}_{suffix}", f"{name}-{suffix}".replace("_", "-")
    cls = "".join(part.capitalize() for part in name.split("_")) + cls_suffix
    fill = dict(name=name, package=package, dist=dist, cls=cls)
    if kind == "surrogate":
        project = dict(what="surrogate", dependencies='"dsmv", "scikit-learn"', selects=f"name: {name}",
                       group="dsmv.surrogates", module="model", option=f"dsmv-train surrogate={name}",
                       config_group="surrogate")
        return {
            "pyproject.toml": PYPROJECT.format(**fill, **project),
            f"{package}/__init__.py": f'"""The {name} surrogate for dsmv."""\n',
            f"{package}/model.py": SURROGATE.format(**fill),
            f"{package}/conf/__init__.py": "",
            f"{package}/conf/surrogate/__init__.py": "",
            f"{package}/conf/surrogate/{name}.yaml": SURROGATE_OPTION.format(**fill),
            f"tests/test_{name}.py": SURROGATE_TESTS.format(**fill),
        }
    project = dict(what="soil law", dependencies='"dsmv"', selects=f"soil.law={name}", group="dsmv.soil_laws",
                   module="law", option=f"soil={name}_clay", config_group="soil")
    return {
        "pyproject.toml": PYPROJECT.format(**fill, **project),
        "README.md": README.format(**fill),
        f"{package}/__init__.py": f'"""The {name} soil law for dsmv."""\n',
        f"{package}/law.py": LAW.format(**fill),
        f"{package}/conf/__init__.py": "",
        f"{package}/conf/soil/__init__.py": "",
        f"{package}/conf/soil/{name}_clay.yaml": PROFILE.format(**fill),
        f"tests/test_{name}.py": TESTS.format(**fill),
    }


def write_package(kind: str, name: str, parent: Path) -> Path:
    """Write the ``kind`` package into ``parent/<dist>``; refuse to overwrite anything."""
    files = package_files(kind, name)
    root = Path(parent) / f"{name}-{KINDS[kind][0]}".replace("_", "-")
    if root.exists():
        raise ConfigError("NAME", name, f"{root} exists already; choose another name or folder")
    for relative, text in files.items():
        path = root / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return root
