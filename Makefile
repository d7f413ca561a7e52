# The two commands of the README. Both create .venv when missing and install .[dev] into it.
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.dsmv-installed
DOCS_STAMP := $(VENV)/.dsmv-docs-installed

.PHONY: install run test docs report clean mlflow-screenshots

install: $(STAMP)

$(STAMP): pyproject.toml
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[dev]"
	@touch $(STAMP)

# the default scene as the whole track in 3D (cel3d's default mesh: about 5 s warm on two cores, the
# first run compiles for about a minute and a half); a solver named in ARGS runs instead
run: install
	$(BIN)/dsmv $(if $(filter solver=%,$(ARGS)),,solver=cel3d) $(ARGS)

# the suite in TEST_WORKERS processes (pytest-xdist), a test file's tests in one of them; 0 runs it in this one
TEST_WORKERS ?= 2
test: install
	$(BIN)/python -m pytest -n $(TEST_WORKERS) --dist loadfile $(PYTEST_ARGS)

# The documentation site: installs the docs extra into .venv, builds docs/ into runs/site (strict:
# a broken link or a page missing from mkdocs.yml's nav fails the build).
docs: $(DOCS_STAMP)
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict -d runs/site

$(DOCS_STAMP): pyproject.toml
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet -e ".[docs]"
	@touch $(DOCS_STAMP)

# The verification report from runs, stamped with the commit: docs/verification/report.md (about
# 50 minutes on one core with the other busy); REPORT_ARGS=--quick writes a short one under runs/report/ instead.
report: install
	$(BIN)/dsmv-report $(REPORT_ARGS)

# The MLflow UI as a user sees it: a two-job sweep, dsmv ui over its store, four screenshots in
# headless Chromium (Debian's chromium package) into runs/mlflow_screenshots.
mlflow-screenshots: install
	$(BIN)/python -m dsmv.tracking.mlflow_check runs/mlflow_screenshots

clean:
	rm -rf runs/outputs runs/multirun runs/mlflow.db runs/mlartifacts
