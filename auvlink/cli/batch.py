"""``auvlink batch LOGS_OR_DIRS... --out DIR [--workers N | --scheduler ADDRESS] [--force] [--json] [...]``.

Every mission log (the ``.mcap`` files named, and those under the folders named) goes through the
replay pipeline on a Dask cluster (:mod:`auvlink.pipeline.batch`): one folder ``DIR/<mission>/`` per log
with the files of ``auvlink replay`` plus ``batch.json``, then ``DIR/catalogue.geojson`` and
``DIR/catalogue.csv`` (the site catalogue with new / missing / stable flags) and ``DIR/batch.json``.
A mission already done with the same log, model and settings is skipped; a log that fails, or runs
past ``--mission-timeout`` (default 2 h), is reported and the others go on (exit status 1 when any
failed). Files under DIR are never taken as missions, a ``--model``, ``--config`` or log named under
DIR is refused (exit 2), a ``--scheduler`` that is no address (the empty one included) is one line
before any work, and DIR is locked for the run (a second batch into it is refused). A summary table
ends the run (``--json``: the run as JSON on stdout instead).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path
from typing import Any

from auvlink.errors import AuvlinkError
from auvlink.jsonutil import to_jsonable
from auvlink.pipeline.batch_guard import DEFAULT_MISSION_TIMEOUT_S


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("inputs", nargs="+", type=Path, metavar="LOG_OR_DIR",
                   help="mission logs (.mcap), or folders searched for them")
    p.add_argument("--out", type=Path, required=True, help="output folder (one sub-folder per mission)")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, default=2,
                       help="worker processes of the local cluster (default 2; one mission at a time each)")
    where.add_argument("--scheduler", default=None, metavar="ADDRESS",
                       help="an existing Dask scheduler (tcp://host:8786) instead of a local cluster")
    p.add_argument("--force", action="store_true",
                   help="write into a non-batch DIR, and reprocess missions done with another log, model or settings")
    p.add_argument("--model", type=Path, default=None, help="classifier checkpoint (default: the shipped one)")
    p.add_argument("--config", type=Path, default=None,
                   help="vehicle configuration (TOML) for every log instead of the one each log stores")
    p.add_argument("--no-classify", action="store_true", help="stop after clustering")
    p.add_argument("--no-report", action="store_true", help="skip each mission's report.html")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--mission-timeout", type=float, default=DEFAULT_MISSION_TIMEOUT_S, metavar="S",
                   help=f"stop a mission after S seconds and report it as timed out; the others go on (default "
                        f"{DEFAULT_MISSION_TIMEOUT_S:.0f}: a 30-minute mission takes about 30 s)")
    p.add_argument("--json", action="store_true", help="print the run (batch.json) on stdout instead of the table")


def _fmt(v: Any, spec: str = "") -> str:
    if v is None:
        return "-"
    return format(v, spec) if spec else str(v)


def summary_table(run: dict[str, Any]) -> str:
    """The end-of-run table: one row per mission, then the totals and the catalogue."""
    rows = [("mission", "status", "objects", "mission min", "wall s", "x real time", "worker peak MB", "note")]
    for m in run["missions"]:
        dur, wall = m.get("duration_s"), m.get("wall_s") or 0.0
        xrt = dur / wall if m["status"] == "done" and dur and wall else None
        rows.append((m["mission"], m["status"], _fmt(m.get("detections")),
                     _fmt(dur / 60.0 if dur else None, ".1f"), _fmt(wall, ".1f"), _fmt(xrt, ".1f"),
                     _fmt(m.get("peak_rss_mb"), ".0f"), m.get("error", "")[:100]))
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]) - 1)]
    lines = ["  ".join(c.ljust(w) for c, w in zip(r[:-1], widths, strict=True)) + ("  " + r[-1] if r[-1] else "")
             for r in rows]  # the note (an error) last, unpadded
    lines.insert(1, "  ".join("-" * w for w in widths))
    counts = run["counts"]
    lines.append(f"{len(run['missions'])} mission(s): {counts.get('done', 0)} done, {counts.get('skipped', 0)} "
                 f"skipped, {counts.get('failed', 0)} failed, in {run['wall_s']:.1f} s on {run['cluster']}")
    cat = run.get("catalogue") or {}
    if cat:
        st = cat["status"]
        lines.append(f"catalogue: {cat['objects']} object(s) from {cat['missions']} mission(s) "
                     f"({st['stable']} stable, {st['new']} new, {st['missing']} missing) -> {cat['geojson']}, "
                     f"{cat['csv']}")
        if not str(cat.get("frame", "")).startswith("WGS84"):
            lines.append("catalogue positions are datum-less (local NED metres): the logs have no GNSS georeference")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    from auvlink.pipeline.batch import check_batch_dir, discover_logs, make_tasks, run_batch
    from auvlink.pipeline.batch_guard import check_scheduler_address
    from auvlink.pipeline.run_guard import BATCH_FILES, output_dir_lock, refuse_input_overwrite

    if args.scheduler is not None:
        check_scheduler_address(args.scheduler)
    if not args.mission_timeout > 0:
        raise AuvlinkError(f"--mission-timeout must be > 0 s, got {args.mission_timeout}")
    logs = discover_logs(args.inputs, exclude=args.out)
    # a mission folder is replaced whole when reprocessed; the top-level files on every run
    refuse_input_overwrite([*logs, args.model, args.config], folder=("--out", args.out),
                           writes=lambda rel: len(rel.parts) > 1 or rel.name in BATCH_FILES)
    check_batch_dir(args.out, args.force)  # before any work
    with output_dir_lock(args.out, force=True):  # its content is checked above: a batch's folder resumes
        check_batch_dir(args.out, args.force)  # again under the lock: a run that ended meanwhile
        tasks = make_tasks(logs, args.out, model=args.model, classify=not args.no_classify,
                           report=not args.no_report, config=args.config, force=args.force)
        tasks = [dataclasses.replace(t, timeout_s=args.mission_timeout) for t in tasks]
        result = run_batch(tasks, args.out, workers=args.workers, scheduler=args.scheduler,
                           progress=not args.quiet)
    doc = to_jsonable(result.to_dict())
    for o in result.failed:
        print(f"auvlink: error: {o.log}: {o.error}", file=sys.stderr)
    if args.json:
        print(json.dumps(doc, allow_nan=False))
    else:
        print(summary_table(doc))
    return 1 if result.failed else 0
