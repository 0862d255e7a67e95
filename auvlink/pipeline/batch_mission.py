"""One mission of ``auvlink batch``: the task a Dask worker runs (and the fingerprint that skips it).

:func:`run_mission` is what ``auvlink replay LOG --out DIR/<mission>`` does (:func:`~auvlink.pipeline.
process.run_log`, :func:`~auvlink.pipeline.outputs.write_outputs`, :func:`~auvlink.pipeline.report.
write_report` into an :func:`~auvlink.atomic.atomic_dir`), plus ``batch.json``: the mission's
fingerprint (SHA-256 of the log, streamed in 1 MiB blocks; the settings, with the SHA-256 of the model
checkpoint and of a ``--config`` file), its log start and end times, its site datum and its covered
seabed (:mod:`auvlink.pipeline.coverage`) for the catalogue. ``batch.json`` is written inside the
atomic folder, so a mission folder that has it is whole.

A log must start with the MCAP magic before it is hashed (:func:`~auvlink.pipeline.batch_guard.
check_mcap_magic`). A mission whose folder holds a ``batch.json`` with the same fingerprint, and every
output it lists with the same SHA-256, is skipped (a batch resumes where it stopped); a folder whose
outputs were edited or deleted, or whose ``batch.json`` is unreadable while it holds nothing but a
mission's files, is processed again; a folder from another log, model or settings, or one holding
other files, is replaced only with ``force``. A mission that runs past ``timeout_s`` stops
(:func:`~auvlink.pipeline.batch_guard.time_limit`) and is reported as timed out. Every failure becomes
an outcome with ``status = "failed"`` and a one-line ``error``: the other missions go on.

Memory: one mission at a time per worker process (the worker's lock, :data:`_ONE_AT_A_TIME`, also holds
on a worker started with several threads); the log is streamed chunk by chunk by the reader.
"""

from __future__ import annotations

import json
import math
import os
import resource
import socket
import threading
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from auvlink.errors import AuvlinkError
from auvlink.file_digest import sha256_file
from auvlink.pipeline.batch_guard import (
    MissionTimeout,
    check_mcap_magic,
    edited,
    only_mission_files,
    output_digests,
    outputs_intact,
    seal,
    sealed,
    time_limit,
)

BATCH_FILE = "batch.json"
MISSION_FORMAT = "auvlink-batch-mission/1"

_ONE_AT_A_TIME = threading.Lock()


@dataclass(frozen=True)
class MissionTask:
    """What a worker needs for one mission (paths as the workers see them: a shared file system)."""

    mission: str
    log: str
    out: str  # the mission's folder, DIR/<mission>
    settings: dict[str, Any]  # the fingerprint's settings (see :func:`auvlink.pipeline.batch.settings_of`)
    model: str | None = None
    config: str | None = None
    classify: bool = True
    report: bool = True
    force: bool = False
    timeout_s: float | None = None  # --mission-timeout (s): None for no limit


@dataclass
class Outcome:
    """What became of one mission (``status``: done, skipped or failed)."""

    mission: str
    log: str
    status: str
    error: str = ""
    detections: int | None = None
    duration_s: float | None = None  # mission time in the log (s)
    wall_s: float = 0.0  # worker time spent on it (checksum included)
    log_bytes: int | None = None
    worker: str = ""
    peak_rss_mb: float | None = None  # the worker process's peak resident memory so far (MB)
    t_start: float = 0.0  # when the worker began it (s since the UNIX epoch)
    record: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d.pop("record")
        return d


def read_record(folder: Path) -> dict[str, Any] | None:
    """A mission folder's ``batch.json`` (None when absent or unreadable)."""
    try:
        doc = json.loads((folder / BATCH_FILE).read_text())
    except (OSError, ValueError):
        return None
    return doc if isinstance(doc, dict) and doc.get("format") == MISSION_FORMAT else None


def _worker_name() -> str:
    return f"{socket.gethostname()}:{os.getpid()}"


def run_mission(task: MissionTask) -> Outcome:
    """The Dask task: skip, process or fail one mission; never raises for the mission's own faults."""
    out = Outcome(task.mission, task.log, "failed", worker=_worker_name())
    with _ONE_AT_A_TIME:
        out.t_start, t0 = time.time(), time.perf_counter()
        try:
            with time_limit(task.timeout_s):
                _run(task, out)
        except MissionTimeout:
            out.error = f"timed out after {task.timeout_s:g} s (--mission-timeout); its folder keeps what it had"
        except AuvlinkError as exc:
            out.error = str(exc)
        except Exception as exc:  # the task's boundary: one mission's fault must not stop the batch
            out.error = f"{type(exc).__name__}: {exc}"
    out.wall_s = time.perf_counter() - t0
    out.peak_rss_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e3  # Linux: kB
    if out.error:
        out.status = "failed"
        out.error = " ".join(out.error.split()).removeprefix(f"{task.log}: ")  # one line; the log is named apart
    return out


def _run(task: MissionTask, out: Outcome) -> None:
    from auvlink.version import __version__

    if task.settings.get("auvlink") != __version__:
        raise AuvlinkError(f"this worker has auvlink {__version__}, the client {task.settings.get('auvlink')}; "
                           "install the same version on the workers")
    log, folder = Path(task.log), Path(task.out)
    if not log.is_file():
        raise AuvlinkError(f"{log}: no such log")
    out.log_bytes = log.stat().st_size
    check_mcap_magic(log)  # before the checksum: a large file that is no log is read for 8 bytes, not whole
    digest = sha256_file(log)
    previous = read_record(folder)
    same = previous is not None and previous.get("log_sha256") == digest and previous.get("settings") == task.settings
    if previous is not None and same and sealed(previous) and outputs_intact(folder, previous):
        out.status, out.record = "skipped", previous
        out.detections, out.duration_s = previous.get("detections"), previous.get("duration_s")
        return
    # this batch's own folder, damaged: outputs or record edited, or a record that cannot be read
    tampered = same or (previous is not None and edited(previous)) or (previous is None and only_mission_files(folder))
    if folder.is_dir() and os.listdir(folder) and not task.force and not tampered:
        why = ("from another log, model or settings" if previous is not None
               else "without batch.json (not a finished batch mission)")
        raise AuvlinkError(f"{folder} exists {why}; give --force to reprocess it, or another --out")
    record = process_mission(task, digest)
    out.status, out.record = "done", record
    out.detections, out.duration_s = record["detections"], record["duration_s"]


def process_mission(task: MissionTask, digest: str) -> dict[str, Any]:
    """Replay the log into the mission folder (the files of ``auvlink replay``) plus ``batch.json``."""
    from auvlink.atomic import atomic_dir
    from auvlink.config import load_config
    from auvlink.pipeline.object_labels import TORCH_THREADS
    from auvlink.pipeline.outputs import write_outputs
    from auvlink.pipeline.process import run_log
    from auvlink.pipeline.report import write_report
    from logs_format import MissionLogReader

    log, folder = Path(task.log), Path(task.out)
    t0 = time.perf_counter()
    with MissionLogReader(log) as reader:
        start_ns, end_ns = reader.start_ns, reader.end_ns
        if start_ns is None:  # replay would give an empty mission: in a batch that is a failed log
            raise AuvlinkError(f"{log}: no readable message ({reader.loss.describe()})")
    vehicle = load_config(Path(task.config)) if task.config is not None else None
    model = Path(task.model) if task.model is not None else None
    result = run_log(log, model=model, classify=task.classify, progress=False, config=vehicle,
                     torch_threads=TORCH_THREADS["batch"])
    with atomic_dir(folder) as tmp:
        summary = write_outputs(result, tmp)
        if task.report:
            write_report(result, summary, tmp)
        record = mission_record(task, digest, result, start_ns, end_ns, time.perf_counter() - t0)
        record = seal({**record, "outputs": output_digests(tmp)})  # an edited folder is processed again
        (tmp / BATCH_FILE).write_text(json.dumps(record, indent=1, allow_nan=False) + "\n")
    return record


def mission_record(task: MissionTask, digest: str, result: Any, start_ns: int | None, end_ns: int | None,
                   wall_s: float) -> dict[str, Any]:
    """``batch.json`` of a processed mission (JSON-ready)."""
    from auvlink.jsonutil import to_jsonable
    from auvlink.pipeline.coverage import coverage_polygon, geometry_to_json, onset_directions

    setup = result.setup
    track = mission_track(result)
    mount = setup.sonar_mounting.rpy
    half_fov = _half_fov(result.geometry)
    dirs = onset_directions(setup.sonar.tilt, setup.sonar.spread, half_fov, mount_pitch=mount[1], mount_yaw=mount[2])
    cover = coverage_polygon(track, dirs, window=(setup.sonar.window_start, setup.sonar.window_end))
    georef = getattr(result, "georef", None) or {}
    site = georef.get("datum") or setup.site  # the datum the detections' lat/lon refer to, else the config's
    lat, lon = (site.get("latitude"), site.get("longitude")) if isinstance(site, dict) else \
        (getattr(site, "latitude", None), getattr(site, "longitude", None))
    datum = {"latitude": lat, "longitude": lon} if lat is not None and lon is not None else None
    duration = (end_ns - start_ns) * 1e-9 if start_ns is not None and end_ns is not None else None
    rec = {
        "format": MISSION_FORMAT, "mission": task.mission, "log": str(Path(task.log).absolute()),
        "log_sha256": digest, "log_bytes": Path(task.log).stat().st_size, "settings": task.settings,
        "start_ns": start_ns, "end_ns": end_ns, "duration_s": duration,
        "detections": len(result.detections), "datum": datum,
        "georeferenced": bool(georef.get("georeferenced", False)),
        "coverage": {"frame": "local NED of the mission, x = east, y = north (m)",
                     "area_m2": round(float(cover.area), 3), "geometry": geometry_to_json(cover),
                     "altitude_m": float(np.nanmedian(track.altitude)) if len(track) else None},
        "wall_s": wall_s, "worker": _worker_name(),
    }
    out: dict[str, Any] = to_jsonable(rec)
    return out


def _half_fov(geometry: Any) -> float:
    from auvlink.pipeline.coverage import DEFAULT_HALF_FOV

    az = getattr(geometry, "azimuths", None)
    if az is not None and len(az):
        return float(np.max(np.abs(np.asarray(az, dtype=np.float64))))
    fov = getattr(geometry, "fov", None)
    return float(fov) / 2.0 if fov else DEFAULT_HALF_FOV


def mission_track(result: Any) -> Any:
    """The poses for coverage: the result's track table when it has altitude and heading (the geo
    outputs' ``track.csv`` columns), else its positions with the heading of motion and the median
    altitude of the frames the report keeps (or of the seabed under the highlight points)."""
    from auvlink.pipeline.coverage import Track, track_from_positions

    info = getattr(result, "track_info", None) or {}
    if all(k in info for k in ("north", "east", "heading", "altitude")) and len(info["north"]):
        return Track(np.asarray(info["north"], float), np.asarray(info["east"], float),
                     np.radians(np.asarray(info["heading"], float)), np.asarray(info["altitude"], float))
    positions = np.asarray(result.track, dtype=np.float64).reshape(-1, 3)
    alts = [float(np.ravel(s.altitude)[0]) for s in result.strip if np.size(s.altitude)]
    alt = float(np.nanmedian(alts)) if alts and np.isfinite(alts).any() else math.nan
    hp = result.highlight_points
    if not math.isfinite(alt) and hp is not None and len(hp) and len(positions):
        alt = float(np.median(np.asarray(hp)[:, 2]) - np.median(positions[:, 2]))
    return track_from_positions(positions, alt)
