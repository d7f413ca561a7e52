"""The commit recorded with each MLflow run is that of dsmv's own source, not of the working directory."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

import dsmv
from dsmv.tracking.runs import _git_sha

PACKAGE_DIR = Path(dsmv.__file__).resolve().parent


def _git(cwd: Path, *args: str) -> str:
    return subprocess.run(["git", "-C", str(cwd), "-c", "user.name=t", "-c", "user.email=t@example.org", *args],
                          check=True, capture_output=True, text=True).stdout.strip()


def _make_repo(path: Path) -> str:
    path.mkdir(parents=True, exist_ok=True)
    _git(path, "init", "-q")
    (path / "file.txt").write_text("another project\n")
    _git(path, "add", "file.txt")
    _git(path, "commit", "-q", "-m", "another project")
    return _git(path, "rev-parse", "HEAD")


def _dsmv_commit() -> str:
    out = subprocess.run(["git", "-C", str(PACKAGE_DIR), "rev-parse", "HEAD"], capture_output=True, text=True)
    if out.returncode != 0:
        pytest.skip("dsmv is not imported from a git checkout here")
    return out.stdout.strip()


def test_commit_is_dsmv_s_own_from_another_repo(tmp_path, monkeypatch):
    other = _make_repo(tmp_path / "other")
    monkeypatch.chdir(tmp_path / "other")
    expected = _dsmv_commit()
    assert expected != other
    assert _git_sha() == expected


def test_no_commit_outside_a_checkout(tmp_path, monkeypatch):
    """An installed copy of dsmv (say from a wheel) has no commit, whatever the working directory."""
    _make_repo(tmp_path / "other")
    monkeypatch.chdir(tmp_path / "other")
    site = tmp_path / "site-packages" / "dsmv"
    site.mkdir(parents=True)
    assert _git_sha(site) is None


def test_no_commit_for_an_untracked_copy_inside_a_checkout(tmp_path):
    """A wheel installed into a virtualenv that sits in some repo's work tree is not that repo's commit."""
    _make_repo(tmp_path / "project")
    site = tmp_path / "project" / ".venv" / "lib" / "site-packages" / "dsmv"
    site.mkdir(parents=True)
    (site / "__init__.py").write_text("")
    assert _git_sha(site) is None
