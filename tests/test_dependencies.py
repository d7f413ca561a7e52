"""Every third-party module the package imports is a declared dependency of pyproject.toml."""

from __future__ import annotations

import ast
import re
import sys
from pathlib import Path

import pytest

tomllib = pytest.importorskip("tomllib")  # Python 3.11+

ROOT = Path(__file__).resolve().parent.parent
SOURCE_DIRS = ("dsmv", "plugins", "hydra_plugins")

#: top-level names of this project's own packages
FIRST_PARTY = {"dsmv", "dsmv_plugins", "hydra_plugins"}
#: folders that run only with an extra installed: their imports may be declared in that extra
EXTRA_OF = {"hydra_plugins/dsmv_launcher": "cluster"}

#: import name -> distribution name, where the two differ
DISTRIBUTION = {
    "sklearn": "scikit-learn",
    "yaml": "pyyaml",
    "xgboost": "xgboost-cpu",
    "hydra": "hydra-core",
}


def _normalize(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def imported_modules() -> dict[str, set[str]]:
    """Top-level module name -> the source files that import it (absolute imports only)."""
    found: dict[str, set[str]] = {}
    for folder in SOURCE_DIRS:
        for path in sorted((ROOT / folder).rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
                if isinstance(node, ast.Import):
                    names = [alias.name for alias in node.names]
                elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                    names = [node.module]
                else:
                    continue
                for name in names:
                    found.setdefault(name.split(".")[0], set()).add(str(path.relative_to(ROOT)))
    return found


def declared_distributions(extra: str | None = None) -> set[str]:
    """The distributions [project] depends on, and those of ``extra`` besides."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    specs = project["dependencies"] + (project["optional-dependencies"][extra] if extra else [])
    return {_normalize(re.match(r"[A-Za-z0-9_.-]+", spec).group()) for spec in specs}


def test_every_third_party_import_is_a_declared_dependency():
    missing = {}
    for module, files in imported_modules().items():
        if module in sys.stdlib_module_names or module in FIRST_PARTY:
            continue
        distribution = _normalize(DISTRIBUTION.get(module, module))
        for file in files:
            extra = next((e for folder, e in EXTRA_OF.items() if file.startswith(folder + "/")), None)
            if distribution not in declared_distributions(extra):
                missing.setdefault(distribution, []).append(file)
    assert not missing, f"imported but not in [project] dependencies (or the extra of its folder): {missing}"


def test_the_scan_sees_the_imports():
    """The scan is not vacuous: it finds modules every part of the package imports."""
    modules = imported_modules()
    assert {"numpy", "numba", "hydra", "mlflow", "sklearn", "xgboost"} <= set(modules)
