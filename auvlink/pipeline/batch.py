"""``auvlink batch``: many mission logs through the replay pipeline on a Dask cluster, then the site catalogue.

The cluster is :mod:`dask.distributed`'s: a :class:`~distributed.LocalCluster` by default (``workers``
processes of one thread each, no dashboard), or an existing scheduler given by address
(``tcp://host:8786``: a cluster started by hand, with dask-jobqueue or on Kubernetes; its workers must
see the logs and ``DIR`` at the same paths and have this package installed). Each mission is one task,
:func:`auvlink.pipeline.batch_mission.run_mission`; the client submits them all, collects the outcomes as
they complete (a progress bar over missions on a terminal), then builds the catalogue from every finished
mission folder (:mod:`auvlink.pipeline.catalogue`) and writes ``DIR/batch.json``: the run's outcomes.

``DIR`` may be new, empty or the folder of an earlier batch (it has ``batch.json``): a batch resumes
there, skipping the missions already done with the same log, model and settings. Anything else needs
``force``.
"""

from __future__ import annotations

import json
import os
import time
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from auvlink.atomic import LOCK_NAME, check_writable_folder, write_text
from auvlink.errors import AuvlinkError, OutputError
from auvlink.file_digest import sha256_file
from auvlink.jsonutil import to_jsonable
from auvlink.pipeline.batch_guard import check_scheduler_address
from auvlink.pipeline.batch_mission import MissionTask, Outcome, run_mission
from auvlink.safe_names import UniqueNames, path_inside, safe_name
from auvlink.version import __version__

RUN_FILE = "batch.json"
RUN_FORMAT = "auvlink-batch/1"
LOG_SUFFIX = ".mcap"
WAIT_WORKERS_S = 60.0  # how long a scheduler without workers is given to get one


def discover_logs(inputs: Iterable[Path], exclude: Path | None = None) -> list[Path]:
    """The logs named, and every ``*.mcap`` under the folders named (recursively, hidden and ``.partial``
    files left out, and anything under ``exclude``: the batch's own ``--out``, whose ``results.mcap``
    files are outputs, not missions), each once, in the order given (a folder's logs sorted by path)."""
    out: list[Path] = []
    seen: set[str] = set()
    inside = (lambda q: os.path.realpath(q).startswith(os.path.join(os.path.realpath(exclude), ""))) \
        if exclude is not None else (lambda q: False)
    for p in inputs:
        if p.is_dir():
            found = sorted(q for q in p.rglob(f"*{LOG_SUFFIX}")
                           if q.is_file() and not any(part.startswith(".") for part in q.relative_to(p).parts)
                           and not inside(q))
        elif p.is_file():
            if inside(p):
                raise AuvlinkError(f"{p} is under --out {exclude}: the batch's own files are outputs, not missions")
            found = [p]
        else:
            raise AuvlinkError(f"{p}: no such log or folder")
        for q in found:
            key = os.path.realpath(q)
            if key not in seen:
                seen.add(key)
                out.append(q)
    if not out:
        outside = f" outside --out {exclude} (its files are outputs, not missions)" if exclude is not None else ""
        raise AuvlinkError(f"no {LOG_SUFFIX} logs in {', '.join(str(p) for p in inputs)}{outside}")
    return out


def mission_names(logs: Sequence[Path]) -> list[str]:
    """One folder name per log: its file name without ``.mcap``; logs of the same name get their parent
    folder's name in front (``2025-mission``), then a number, so names stay stable across runs. Names are
    made safe (:func:`auvlink.safe_names.safe_name`: ``..mcap`` gives ``mission``, never a way out of
    ``DIR``) and never those of the batch's own files."""
    stems = Counter(safe_name(p.stem, "mission") for p in logs)
    names = UniqueNames(reserved=(RUN_FILE, "catalogue.geojson", "catalogue.csv"), fallback="mission")
    out: list[str] = []
    for p in logs:
        stem = safe_name(p.stem, "mission")
        name = stem if stems[stem] == 1 else f"{safe_name(p.absolute().parent.name, 'mission')}-{stem}"
        out.append(names.name_for(name, fresh=True))
    return out


def default_model() -> Path:
    """The shipped classifier checkpoint (found without importing torch)."""
    return Path(str(resources.files("classify").joinpath("data", "pointnet_default.pt")))


def settings_of(model: Path | None, classify: bool, report: bool, config: Path | None) -> dict[str, Any]:
    """The settings part of a mission's fingerprint: the package version, the model checkpoint's SHA-256
    (when classifying; a ``--model`` is read and checked first: its inference export when that matches it,
    :func:`classify.inference_export.matching_export`, else the checkpoint,
    :func:`classify.checkpoint.read_checkpoint`),
    the ``--config`` file's SHA-256, and the switches."""
    m = model if model is not None else default_model()
    if classify and not m.is_file():
        raise AuvlinkError(f"--model {m}: no such checkpoint")
    if classify and model is not None:  # checked once here (every field), not failed by each mission
        from classify.inference_export import matching_export

        if matching_export(model)[0] is None:  # with a matching export the workers never load the .pt (nor torch)
            from classify.checkpoint import read_checkpoint

            read_checkpoint(model)
    if config is not None and not config.is_file():
        raise AuvlinkError(f"--config {config}: no such file")
    return {"auvlink": __version__, "classify": classify, "report": report,
            "model_sha256": sha256_file(m) if classify else None,
            "config_sha256": sha256_file(config) if config is not None else None}


def check_batch_dir(out: Path, force: bool) -> None:
    """``DIR`` must be new, empty or an earlier batch's folder, unless ``force``; and writable."""
    if os.path.lexists(out) and not out.is_dir():
        raise OutputError(f"--out {out} exists and is not a folder; give a new folder")
    if out.is_dir() and not force and set(os.listdir(out)) - {LOCK_NAME} and not _is_batch_dir(out):
        raise OutputError(f"{out} is not empty and not an auvlink batch folder (no {RUN_FILE}); give --force to "
                          "write into it, or another --out")
    check_writable_folder(out, f"output folder {out}")


def _is_batch_dir(out: Path) -> bool:
    try:
        return bool(json.loads((out / RUN_FILE).read_text()).get("format") == RUN_FORMAT)
    except (OSError, ValueError, AttributeError):
        return False


@dataclass
class BatchRun:
    """What a batch did: the outcomes (in the order of the logs), the catalogue summary, the cluster."""

    outcomes: list[Outcome]
    cluster: str
    workers: int
    wall_s: float
    catalogue: dict[str, Any] = field(default_factory=dict)

    @property
    def failed(self) -> list[Outcome]:
        return [o for o in self.outcomes if o.status == "failed"]

    def to_dict(self) -> dict[str, Any]:
        return {"format": RUN_FORMAT, "auvlink": __version__, "cluster": self.cluster, "workers": self.workers,
                "wall_s": self.wall_s, "missions": [o.to_dict() for o in self.outcomes],
                "counts": dict(Counter(o.status for o in self.outcomes)), "catalogue": self.catalogue}


def make_tasks(logs: Sequence[Path], out: Path, *, model: Path | None, classify: bool, report: bool,
               config: Path | None, force: bool) -> list[MissionTask]:
    settings = settings_of(model, classify, report, config)
    return [MissionTask(mission=name, log=str(log.absolute()), out=str(path_inside(out, name).absolute()),
                        settings=settings,
                        model=str(model.absolute()) if model is not None else None,
                        config=str(config.absolute()) if config is not None else None,
                        classify=classify, report=report, force=force)
            for log, name in zip(logs, mission_names(logs), strict=True)]


def open_client(workers: int, scheduler: str | None) -> tuple[Any, Any, str]:
    """A Dask client: on ``scheduler`` when given, else on a new local cluster; returns (client, cluster
    or None, description)."""
    import logging

    from distributed import Client, LocalCluster

    if scheduler is not None:
        check_scheduler_address(scheduler)  # an empty address is refused, never a local cluster
        try:
            client = Client(scheduler)  # waits up to distributed.comm.timeouts.connect (30 s by default)
        except (OSError, TimeoutError) as exc:
            raise AuvlinkError(f"--scheduler {scheduler}: cannot connect ({exc}); is a dask scheduler running "
                               "there? (dask scheduler --host HOST --port 8786)") from exc
        try:
            client.wait_for_workers(1, timeout=WAIT_WORKERS_S)
        except (OSError, TimeoutError) as exc:
            client.close()
            raise AuvlinkError(f"--scheduler {scheduler}: no worker connected within {WAIT_WORKERS_S:.0f} s; start "
                               f"some (dask worker {scheduler} --nthreads 1)") from exc
        return client, None, f"scheduler {scheduler}"
    if workers < 1:
        raise AuvlinkError(f"--workers must be >= 1, got {workers}")
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                           silence_logs=logging.ERROR)
    return Client(cluster), cluster, f"local cluster of {workers} worker process(es)"


def run_batch(tasks: Sequence[MissionTask], out: Path, *, workers: int = 2, scheduler: str | None = None,
              progress: bool = True) -> BatchRun:
    """Run every task on the cluster, then write the catalogue and ``DIR/batch.json`` (also when the run
    fails: then with its ``error`` and the outcomes so far, the missions not run as failed)."""
    t0 = time.perf_counter()
    out.mkdir(parents=True, exist_ok=True)
    outcomes: dict[str, Outcome] = {}
    try:
        run = _run_on_cluster(tasks, out, outcomes, workers, scheduler, progress)
    except BaseException as exc:  # batch.json says the run failed and what it did: never the last run's
        failed = BatchRun([outcomes.get(t.mission) or Outcome(t.mission, t.log, "failed", error="not run")
                           for t in tasks], "", 0, time.perf_counter() - t0)
        doc = {**failed.to_dict(), "error": " ".join(f"{type(exc).__name__}: {exc}".split())}
        write_text(out / RUN_FILE, json.dumps(to_jsonable(doc), indent=1, allow_nan=False) + "\n")
        raise
    run.wall_s = time.perf_counter() - t0
    write_text(out / RUN_FILE, json.dumps(to_jsonable(run.to_dict()), indent=1, allow_nan=False) + "\n")
    return run


def _run_on_cluster(tasks: Sequence[MissionTask], out: Path, outcomes: dict[str, Outcome], workers: int,
                    scheduler: str | None, progress: bool) -> BatchRun:
    """The missions on the cluster (``outcomes`` filled as they end), then the catalogue."""
    from distributed import as_completed

    from auvlink.progress import progress_bar

    client, cluster, what = open_client(workers, scheduler)
    try:
        n_workers = len(client.scheduler_info().get("workers", {})) or workers
        futures = {client.submit(run_mission, t, key=f"auvlink-mission-{t.mission}-{os.urandom(4).hex()}",
                                 pure=False, retries=0): t for t in tasks}
        bar = progress_bar(total=len(tasks), unit="mission", desc="batch", enabled=progress)  # on a terminal only
        for fut in as_completed(futures):
            task = futures[fut]
            if fut.status == "finished":
                oc: Outcome = fut.result()
            else:  # the worker died (out of memory, killed): the task's own handler never ran
                try:
                    exc = fut.exception()
                except Exception as why:  # cancelled: there is no exception to fetch
                    exc = why
                oc = Outcome(task.mission, task.log, "failed", error=" ".join(f"{type(exc).__name__}: {exc}".split()))
            outcomes[task.mission] = oc
            bar.update(1)
            bar.set_postfix_str(f"{oc.mission} {oc.status}", refresh=False)
        bar.close()
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    run = BatchRun([outcomes[t.mission] for t in tasks], what, n_workers, 0.0)
    run.catalogue = write_site_catalogue(out, [o for o in run.outcomes if o.status != "failed"])
    return run


def write_site_catalogue(out: Path, finished: Sequence[Outcome]) -> dict[str, Any]:
    """The catalogue of the finished missions: ``DIR/catalogue.geojson`` and ``.csv``; returns its summary."""
    from auvlink.pipeline.catalogue import build_catalogue
    from auvlink.pipeline.catalogue_io import load_mission, status_counts, write_catalogue

    missions = [load_mission(out / o.mission) for o in finished]
    cat = build_catalogue(missions)
    gj, cs = write_catalogue(cat, out)
    return {"geojson": str(gj), "csv": str(cs), "objects": len(cat.objects), "missions": len(missions),
            "frame": cat.frame.note, "status": status_counts(cat)}
