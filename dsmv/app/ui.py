"""``dsmv ui``: the MLflow UI on the project's store, on the loopback address, opened on an experiment's runs.

The store is the one ``dsmv`` writes to, read from the config tree (``tracking`` and ``paths``, with
the same overrides as ``dsmv``: ``dsmv ui paths.runs_dir=/data/runs``). The server runs with one
worker and no job runner (:mod:`dsmv.tracking.ui`); the command prints the link that opens the
experiment's runs list in MLflow's classic view and waits. Ctrl-C (or SIGTERM) stops the server and
exits 130; a mistake (an unknown experiment, a port in use, no store yet) is one line and exit 2.
"""

from __future__ import annotations

import argparse
import json
import signal
import sys
import urllib.request
from pathlib import Path

from dsmv.results import EXIT_CODES
from dsmv.tracking import ui

PROG = "dsmv ui"
#: the port ``dsmv ui`` takes when it is free (``tracking=server``'s address), else any free one
DEFAULT_PORT = 5000
#: the config keys whose overrides locate a run's store and experiment
LOCATING = ("paths", "tracking", "experiment", "study")
#: in the runs dir: the server's own log
LOG_FILE = "mlflow_ui.log"


def command_for(overrides) -> str:
    """The ``dsmv ui`` command that opens the store and the experiment a run with these overrides wrote to:
    with those of them that locate them (``paths.runs_dir=…``, ``tracking.uri=…``, ``experiment=…``)."""
    import shlex

    where = [o for o in overrides if o.lstrip("+~").split("=", 1)[0].split(".", 1)[0] in LOCATING]
    return shlex.join([".venv/bin/dsmv", "ui", *where])


class UserError(Exception):
    """What ``dsmv ui`` cannot do as asked: its one-line message, exit code 2."""


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog=PROG, description="Start the MLflow UI on the loopback address over dsmv's store (the one tracking=local "
                               "writes to) and print the link to an experiment's runs. Ctrl-C stops it (exit 130).",
        epilog="Exit codes: 130 stopped by Ctrl-C or SIGTERM; 2 a mistake, one line on stderr (an unknown experiment, "
               "a port in use, no store yet); 1 the server failed; 0 it ended by itself.")
    p.add_argument("--port", type=int, default=None,
                   help=f"the port on 127.0.0.1 (default: {DEFAULT_PORT} if free, else a free one)")
    p.add_argument("--experiment", metavar="NAME", default=None,
                   help="the experiment to open, dsmv-<study> or <study> (default: the study's, dsmv-default_scene, "
                        "if the store has it, else the one with the latest run)")
    p.add_argument("overrides", nargs="*", metavar="KEY=VALUE",
                   help="config overrides that locate the store and the study, as for dsmv (paths.runs_dir=…, "
                        "experiment=study_strength)")
    return p


def store_of(overrides: list[str]):
    """The composed config's tracking settings, runs dir and study, for these overrides."""
    from dsmv.config.scene import build_tracking
    from dsmv.config.tree import compose
    from dsmv.errors import DsmvError

    try:
        cfg = compose("config", overrides)
        tracking = build_tracking(cfg)
    except DsmvError as error:
        raise UserError(str(error)) from None
    except Exception as error:  # Hydra's: an unknown key or option
        first = next((line for line in str(error).splitlines() if line.strip()), type(error).__name__)
        raise UserError(f"cannot compose {' '.join(overrides)}: {first}") from None
    return tracking, Path(str(cfg.paths.runs_dir)), str(cfg.get("study", "default"))


def check_store(tracking) -> tuple[str, str | None]:
    """The store's URI (absolute) and where the server keeps artifacts it is sent (``tracking.artifact_location``
    as a URI), or a :class:`UserError`."""
    from dsmv.tracking.run_writer import artifact_uri, resolve_uri, store_missing

    if not tracking.enabled:
        raise UserError("tracking = disabled: there is no store to browse; leave tracking out (tracking=local)")
    if tracking.uri.startswith(("http://", "https://")):
        raise UserError(f"tracking.uri = {tracking.uri!r}: a tracking server, which serves its own UI there")
    if store_missing(tracking.uri):
        path = Path(tracking.uri[len("sqlite:///"):]).resolve()
        raise UserError(f"no MLflow store at {path} yet: run dsmv first (a scene or a sweep), then dsmv ui")
    return resolve_uri(tracking.uri), artifact_uri(tracking.artifact_location) if tracking.artifact_location else None


def choose_port(asked: int | None) -> int:
    if asked is None:
        return DEFAULT_PORT if not ui.port_in_use(DEFAULT_PORT) else ui.free_port()
    if not 0 < asked < 65536:
        raise UserError(f"--port = {asked}: not a port (1 to 65535)")
    if ui.port_in_use(asked):
        raise UserError(f"--port = {asked}: {ui.LOOPBACK}:{asked} is in use (another MLflow UI?); "
                        f"give another --port, or none for a free one")
    return asked


def _api(base: str, endpoint: str, body: dict) -> dict:
    request = urllib.request.Request(f"{base}/api/2.0/mlflow/{endpoint}", data=json.dumps(body).encode(),
                                     headers={"Content-Type": "application/json"})
    with urllib.request.urlopen(request, timeout=30) as answer:
        return json.load(answer)


def choose_experiment(base: str, asked: str | None, study: str) -> tuple[dict, list[str]]:
    """The experiment to open (``--experiment``, else the study's if it exists, else the one with the
    latest run) and the names of the store's other experiments, from the server's REST API."""
    from dsmv.tracking.runs import experiment_name

    found = _api(base, "experiments/search", {"max_results": 1000}).get("experiments", [])
    experiments = {e["name"]: e for e in found if e["name"] != "Default" or len(found) == 1}
    if not experiments:
        raise UserError("the store holds no experiment yet: run dsmv first (a scene or a sweep), then dsmv ui")
    if asked is not None:
        chosen = experiments.get(asked) or experiments.get(experiment_name(asked))
        if chosen is None:
            raise UserError(f"--experiment = {asked!r}: not in the store; available: {', '.join(sorted(experiments))}")
    elif experiment_name(study) in experiments:
        chosen = experiments[experiment_name(study)]
    else:
        latest = _api(base, "runs/search", {"experiment_ids": [e["experiment_id"] for e in experiments.values()],
                                            "max_results": 1, "order_by": ["attributes.start_time DESC"]})
        ids = [r["info"]["experiment_id"] for r in latest.get("runs", [])]
        by_id = {e["experiment_id"]: e for e in experiments.values()}
        chosen = by_id[ids[0]] if ids else max(experiments.values(), key=lambda e: int(e.get("creation_time", 0)))
    return chosen, sorted(name for name in experiments if name != chosen["name"])


def _stop_on_sigterm(signum, frame):
    raise KeyboardInterrupt


def main(argv: list[str] | None = None) -> int:
    """``dsmv ui``; returns its exit code."""
    args = parser().parse_args(sys.argv[2:] if argv is None else argv)
    try:
        tracking, runs_dir, study = store_of(list(args.overrides))
        uri, artifacts = check_store(tracking)
        port = choose_port(args.port)
    except UserError as error:
        print(f"{PROG}: error: {error}", file=sys.stderr)
        return 2
    log_path = runs_dir.resolve() / LOG_FILE
    log_path.parent.mkdir(parents=True, exist_ok=True)
    previous = signal.signal(signal.SIGTERM, _stop_on_sigterm)
    try:
        with log_path.open("a") as log:
            print(f"{PROG}: starting MLflow on {ui.LOOPBACK}:{port} over {uri} (its log: {log_path})", flush=True)
            with ui.serve(uri, port, artifacts, log=log) as (base, server):
                try:
                    experiment, others = choose_experiment(base, args.experiment, study)
                except UserError as error:
                    print(f"{PROG}: error: {error}", file=sys.stderr)
                    return 2
                more = f"; also in the store: {', '.join(others)} (--experiment NAME)" if others else ""
                print(f"{PROG}: experiment {experiment['name']}{more}")
                print(f"  {ui.runs_list_url(base, experiment['experiment_id'])}")
                print(f"{PROG}: Ctrl-C stops the server", flush=True)
                server.wait()
        print(f"{PROG}: the server stopped by itself (exit code {server.returncode}; see {log_path})", file=sys.stderr)
        return 0 if server.returncode == 0 else 1
    except ui.ServerError as error:
        print(f"{PROG}: error: MLflow did not start: {error}; see {log_path}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"\n{PROG}: stopped", file=sys.stderr)
        return EXIT_CODES["interrupted"]
    finally:
        signal.signal(signal.SIGTERM, previous)
