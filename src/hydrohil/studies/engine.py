"""Run a study on Dask distributed: a LocalCluster of processes on this machine (every core by default) or any
cluster by its scheduler's address (``dask scheduler`` / ``dask worker``, SLURM, Kubernetes, cloud).

Results stream into one Parquet table: rows are written as part files (``results/part-*.parquet``, each
written to a temporary name and renamed, so a killed client leaves whole parts) every ``FLUSH_ROWS`` rows or
``FLUSH_S`` seconds, and merged into ``results.parquet`` at the end. Runs go to the workers in batches of a few
(:func:`batch_size`: a Fig 11 run takes a few ms, about what Dask spends on a task, so one task per run left the
second core to the scheduler and the client), at most ``window`` batches in flight, so memory stays bounded
however many runs. A rerun of the same study into the same folder skips the runs already there; a worker that
dies mid-run has its batch retried by the scheduler (each run's row is written once, keyed by its id).
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hydrohil.errors import InputError
from hydrohil.studies.runs import execute, execute_batch
from hydrohil.studies.study import METRICS
from hydrohil.studies.study import LoadedStudy, load_study

FLUSH_ROWS = 200
FLUSH_S = 5.0


def schema(study: LoadedStudy):
    import pyarrow as pa
    fields = [("run_id", pa.string()), ("index", pa.int64()), ("status", pa.string()), ("error", pa.string())]
    for v in study.study.vary:
        text = v.name in ("scenario", "sequence") or any(isinstance(x, str) for x in (v.values or []))
        fields.append((f"in.{v.name}", pa.string() if text else pa.float64()))
    fields += [(m, pa.float64()) for m in METRICS]
    if study.study.sequence is not None:
        from hydrohil.sequences.sequence import load_sequence
        n = len(load_sequence(study.base).expectations)
        fields += [(f"expect.{i}", pa.string()) for i in range(n)] + [("verdict", pa.string())]
    fields += [("wall_s", pa.float64()), ("worker", pa.string())]
    return pa.schema(fields)


class ResultTable:
    """The study's Parquet table in ``out``: part files while it runs, ``results.parquet`` when merged."""

    def __init__(self, out: Path, schema):
        self.out, self.schema = Path(out), schema
        self.parts = self.out / "results"
        self.parts.mkdir(parents=True, exist_ok=True)
        self.rows: list[dict] = []
        self.ids = self.read_ids()
        self.n_part = max((int(p.stem.split("-")[1]) for p in self.parts.glob("part-*.parquet")), default=-1) + 1
        self.last = time.monotonic()

    def files(self) -> list[Path]:
        merged = self.out / "results.parquet"
        return ([merged] if merged.exists() else []) + sorted(self.parts.glob("part-*.parquet"))

    def read_ids(self) -> set[str]:
        import pyarrow.parquet as pq
        ids: set[str] = set()
        for f in self.files():
            ids.update(pq.read_table(f, columns=["run_id"]).column(0).to_pylist())
        return ids

    def add(self, row: dict) -> bool:
        if row["run_id"] in self.ids:       # (a retried run that had finished elsewhere: written once)
            return False
        self.ids.add(row["run_id"])
        self.rows.append(row)
        if len(self.rows) >= FLUSH_ROWS or time.monotonic() - self.last > FLUSH_S:
            self.flush()
        return True

    def flush(self) -> None:
        import pyarrow as pa
        import pyarrow.parquet as pq
        self.last = time.monotonic()
        if not self.rows:
            return
        cols = {f.name: [r.get(f.name) for r in self.rows] for f in self.schema}
        table = pa.table(cols, schema=self.schema)
        path = self.parts / f"part-{self.n_part:06d}.parquet"
        tmp = path.with_suffix(".tmp")
        pq.write_table(table, tmp)
        tmp.replace(path)
        self.n_part += 1
        self.rows = []

    def merge(self) -> Path:
        """All rows (parts and an earlier merge) into ``results.parquet``, sorted by run index."""
        import pyarrow as pa
        import pyarrow.parquet as pq
        self.flush()
        files = self.files()
        merged = self.out / "results.parquet"
        tables = [pq.read_table(f).cast(self.schema) for f in files]
        table = pa.concat_tables(tables) if tables else self.schema.empty_table()
        idx = np.asarray(table.column("index").to_numpy())
        _, first = np.unique(np.asarray(table.column("run_id").to_pylist()), return_index=True)
        keep = first[np.argsort(idx[first], kind="stable")]
        table = table.take(keep)
        tmp = merged.with_suffix(".tmp")
        pq.write_table(table, tmp)
        tmp.replace(merged)
        for f in files:
            if f != merged:
                f.unlink()
        return merged


@dataclass
class StudyResult:
    out: Path
    table: Path
    runs: int
    ran: int
    skipped: int
    wall_s: float
    workers: int
    summary: dict


def make_client(scheduler: str | None, workers: int | None):
    """A Dask client: of the cluster at ``scheduler``, or of a new LocalCluster of ``workers`` processes (one
    thread each; default every core). Returns (client, cluster or None)."""
    import logging

    from distributed import Client, LocalCluster
    if scheduler:
        try:
            return Client(scheduler, timeout="30s"), None
        except (OSError, TimeoutError) as exc:
            raise InputError(f"no Dask scheduler answered at {scheduler}: {exc}", key="--scheduler") from None
    n = workers or len(os.sched_getaffinity(0))
    cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                           silence_logs=logging.ERROR)
    return Client(cluster), cluster


def run_study(path: str | Path, out: str | Path, *, scheduler: str | None = None, workers: int | None = None,
              progress: bool = True, window: int | None = None, client=None, on_row=None) -> StudyResult:
    """Run every run of the study ``path`` not yet in ``out`` (resume) on Dask; merge ``results.parquet``,
    write ``summary.json``, ``report.md`` and the figures. ``on_row(row)`` is called as rows arrive."""
    from distributed import as_completed
    study = load_study(path)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    digest = study.digest()
    meta_path = out / "study.json"
    if meta_path.exists():
        meta = json.loads(meta_path.read_text())
        if meta.get("digest") != digest:
            raise InputError(f"{out} holds the results of another study (or of this one before it changed: "
                             f"{meta.get('source')}); give a new --out", key="--out")
    runs = study.runs()
    meta_path.write_text(json.dumps({"name": study.name, "source": str(study.source.resolve()), "digest": digest,
                                     "runs": len(runs)}, indent=2) + "\n")
    table = ResultTable(out, schema(study))
    todo = [r for r in runs if r["run_id"] not in table.ids]
    skipped = len(runs) - len(todo)
    own = client is None
    cluster = None
    t0 = time.perf_counter()
    n_workers = 0
    if todo:
        if own:
            client, cluster = make_client(scheduler, workers)
        try:
            n_workers = max(len(client.scheduler_info().get("workers", {})), 1)
            window = window or max(4 * n_workers, 16)
            logs = str((out / "runs").resolve()) if study.study.logs else None
            base = {"study": str(study.source.resolve()), "digest": digest, "logs": logs}
            size = batch_size(len(todo), n_workers)
            batches = iter([todo[i:i + size] for i in range(0, len(todo), size)])
            ac = as_completed()

            def submit(batch):
                ac.add(client.submit(execute_batch, [{**run, **base} for run in batch], pure=False,
                                     key=f"hydrohil-{digest}-{batch[0]['run_id']}-{batch[-1]['run_id']}"))
            for _ in range(window):
                batch = next(batches, None)
                if batch is not None:
                    submit(batch)
            bar = _progress(progress, len(todo), study.name)
            with bar:
                task_id = bar.add_task("runs", total=len(todo))
                for fut in ac:
                    rows = fut.result()
                    fut.release()
                    for row in rows:
                        if table.add(row) and on_row is not None:
                            on_row(row)
                    bar.advance(task_id, len(rows))
                    nxt = next(batches, None)
                    if nxt is not None:
                        submit(nxt)
        finally:
            table.flush()
            if own:
                client.close()
                if cluster is not None:
                    cluster.close()
    merged = table.merge()
    wall = time.perf_counter() - t0
    from hydrohil.studies.report import write_study_report
    summary = write_study_report(study, merged, out, wall_s=wall, ran=len(todo), workers=n_workers)
    return StudyResult(out, merged, len(runs), len(todo), skipped, wall, n_workers, summary)


BATCH_MAX = 8          # runs per task at most (a Fig 11 run: ~5 ms; Dask's own cost per task: a few ms)


def batch_size(runs: int, workers: int) -> int:
    """Runs per task: up to BATCH_MAX, and small enough that every worker gets about four tasks (a short study
    still spreads over the cluster, a killed worker's retry is small)."""
    return max(1, min(BATCH_MAX, runs // (4 * max(workers, 1))))


def _progress(show: bool, total: int, name: str):
    from rich.progress import (BarColumn, MofNCompleteColumn, Progress, ProgressColumn, TextColumn,
                               TimeElapsedColumn, TimeRemainingColumn)
    from rich.text import Text

    class Rate(ProgressColumn):
        def render(self, task):
            return Text("" if task.speed is None else f"{task.speed:.1f} runs/s")
    return Progress(TextColumn(name[:40]), BarColumn(), MofNCompleteColumn(), Rate(), TimeElapsedColumn(),
                    TextColumn("ETA"), TimeRemainingColumn(), disable=not show)


def rerun(path: str | Path, run_id: str, dest: str | Path) -> Path:
    """Write the scenario (or sequence) file of one run of the study, to simulate or test it by hand."""
    import tomli_w

    from hydrohil.studies.runs import run_data
    study = load_study(path)
    run = next((r for r in study.runs() if r["run_id"] == run_id), None)
    if run is None:
        raise InputError(f"no run {run_id!r} in this study (r000000 .. r{len(study.runs()) - 1:06d})", key="--rerun")
    data, kind, _ = run_data(study, run["inputs"])
    dest = Path(dest)
    dest.parent.mkdir(parents=True, exist_ok=True)
    head = "\n".join(f"#   {k} = {v!r}" for k, v in run["inputs"].items())
    dest.write_text(f"# run {run_id} of the study {study.source} ({kind}), inputs:\n{head}\n" + tomli_w.dumps(data))
    return dest
