"""A sweep's progress line, `` (k of N jobs done)``: each finished job gets its own k, however close
together jobs end and in whatever processes they run (dsmv.tracking.runs.sweep_progress)."""

from __future__ import annotations

import multiprocessing
import re

from dsmv.tracking import runs


def test_two_jobs_that_wrote_their_results_before_either_counted_print_different_counts(tmp_path):
    """The joblib launcher's two workers each write result.json, then log to MLflow, then print: the
    count of result.json files was 2 for both. Now the first to report is 2 of 3 and the other 3 of 3."""
    runs.write_sweep_size(tmp_path, 3)
    (tmp_path / "0").mkdir()
    (tmp_path / "0" / "result.json").write_text("{}")
    assert runs.sweep_progress(tmp_path, "0") == " (1 of 3 jobs done)"
    for job in ("1", "2"):
        (tmp_path / job).mkdir()
        (tmp_path / job / "result.json").write_text("{}")
    assert [runs.sweep_progress(tmp_path, job) for job in ("2", "1")] == [" (2 of 3 jobs done)", " (3 of 3 jobs done)"]
    assert [(tmp_path / runs.JOBS_DONE_DIR / str(k)).read_text() for k in (1, 2, 3)] == ["0", "2", "1"]


def _report(sweep_dir, job, queue):
    queue.put(runs.sweep_progress(sweep_dir, job))


def test_jobs_ending_at_once_in_separate_processes_count_one_to_n(tmp_path):
    runs.write_sweep_size(tmp_path, 8)
    context = multiprocessing.get_context("fork")
    queue = context.Queue()
    workers = [context.Process(target=_report, args=(tmp_path, str(k), queue)) for k in range(8)]
    for worker in workers:
        worker.start()
    lines = [queue.get(timeout=60) for _ in workers]
    for worker in workers:
        worker.join(timeout=60)
    assert sorted(int(re.match(r" \((\d) of 8 jobs done\)", line).group(1)) for line in lines) == list(range(1, 9))


def test_a_sweep_of_unknown_size_prints_no_count_but_still_counts_the_job(tmp_path):
    assert runs.sweep_progress(tmp_path, "0") == ""
    assert runs.job_done(tmp_path, "1") == 2
