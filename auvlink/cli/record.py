"""``auvlink record CONFIG.toml --out LOG.mcap [--duration S]``: the ports of a config -> a mission log.

One thread per device reads its driver (a :class:`~auvlink.pipeline.ports.PortReader`: a port that
goes is reopened with exponential backoff, and the gap is marked in the log's ``events`` channel);
every raw frame goes to the log writer (no processing beyond the framer). SIGINT / SIGTERM stop the
readers, write the last chunk and the summary, and close the log cleanly. At the end, one line per
device: frames, bytes, decode errors, reopenings. An existing ``--out`` is replaced only with
``--force``; the log is ``LOG.mcap.partial`` until it is closed (a kill -9 leaves it there, readable
up to its last complete chunk). A full disk stops the recording with one line, exit 1; the log keeps
what was written, readable up to its last complete chunk.
"""

from __future__ import annotations

import argparse
import signal
import sys
import threading
import time
from types import FrameType
from typing import Any

from auvlink.config import load_config
from auvlink.driver import Driver
from auvlink.oculus_driver import driver_for_device
from auvlink.pipeline.ports import EVENT_SCHEMA, EVENT_SCHEMA_NAME, EVENT_TOPIC, PortReader
from logs_format.profile import LogError
from logs_format.writer import MissionLogWriter


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("config", help="vehicle configuration (TOML: [[devices]] name, format, url, ...)")
    parser.add_argument("--out", required=True, help="mission log to write (.mcap)")
    parser.add_argument("--force", action="store_true", help="replace an existing --out")
    parser.add_argument("--duration", type=float, default=None,
                        help="stop after S seconds (default: until Ctrl-C)")
    parser.add_argument("--compression", choices=("zstd", "lz4", "none"), default="zstd")
    parser.add_argument("--flush-interval", type=float, default=1.0,
                        help="close a chunk at least every S seconds (what a crash can lose)")
    parser.add_argument("--quiet", action="store_true", help="no summary at the end")


def record(config_path: str, out: str, duration: float | None = None, *, compression: str = "zstd",
           flush_interval: float = 1.0, stop: threading.Event | None = None) -> dict[str, Any]:
    """Record until ``duration`` s passed or ``stop`` is set; returns per-device counters."""
    config = load_config(config_path)
    stop = stop or threading.Event()
    drivers = [driver_for_device(d.name, d.format, d.url, d.options) for d in config.devices]
    opened: list[Driver] = []
    readers: list[PortReader] = []
    failure: list[str] = []  # the log could not be written (disk full): the recording stops there
    t0 = time.monotonic()
    log = MissionLogWriter(out, compression=compression, flush_interval=flush_interval)

    def failed(exc: LogError) -> None:
        if not failure:
            failure.append(str(exc))
        stop.set()

    def tap(device: str, fmt: str, t_host_ns: int, raw: bytes, t_sensor_ns: int | None = None) -> None:
        if not failure:
            try:
                log(device, fmt, t_host_ns, raw, t_sensor_ns=t_sensor_ns)
            except LogError as exc:
                failed(exc)

    def on_event(ev: dict[str, Any]) -> None:
        if not failure:
            try:
                log.add_json(EVENT_TOPIC, EVENT_SCHEMA_NAME, EVENT_SCHEMA, int(ev["t_ns"]), ev)
            except LogError as exc:
                failed(exc)

    halt = threading.Event()
    try:
        log.add_vehicle_config(config)
        for drv in drivers:
            drv.open()
            opened.append(drv)
            drv.add_raw_listener(tap, sensor_time=True)
        for drv in opened:
            readers.append(PortReader(drv, lambda s: None, halt, on_event=on_event, read_timeout=0.1,
                                      opened=True).start())
        end = None if duration is None else t0 + duration
        while not stop.is_set() and (end is None or time.monotonic() < end):
            if readers and all(r.fatal for r in readers):
                break
            stop.wait(0.1 if end is None else max(0.0, min(0.1, end - time.monotonic())))
    finally:
        halt.set()
        for r in readers:
            r.join()
        for drv in opened:
            drv.close()
        try:
            log.close()  # the last chunk and the summary; after a failure: closed as far as the disk allows
        except LogError as exc:
            failed(exc)
    stats = log.stats()
    elapsed = time.monotonic() - t0
    devices = {}
    by_name = {r.driver.name: r for r in readers}
    for drv in drivers:
        ch = stats.get(drv.name)
        rd = by_name.get(drv.name)
        devices[drv.name] = {"format": drv.format.name, "frames": ch.frames if ch else 0,
                             "bytes": ch.bytes if ch else 0, "decode_errors": drv.stats.decode_errors,
                             "reopens": rd.reopens if rd else 0, "failure": rd.fatal if rd else ""}
    return {"out": out, "seconds": elapsed, "devices": devices, "failure": failure[0] if failure else ""}


def run(args: argparse.Namespace) -> int:
    from auvlink.atomic import check_output_file

    check_output_file(args.out, force=args.force, inputs=[args.config], what="log")
    stop = threading.Event()

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop.set()

    previous = {sig: signal.signal(sig, on_signal) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        result = record(args.config, args.out, args.duration, compression=args.compression,
                        flush_interval=args.flush_interval, stop=stop)
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    if not args.quiet:
        print(f"{result['out']}: {result['seconds']:.1f} s")
        for name, d in result["devices"].items():
            line = f"  {name:<12} {d['format']:<9} {d['frames']:>9} frames {d['bytes']:>12} bytes " \
                   f"{d['decode_errors']:>6} decode errors {d['reopens']:>3} reopenings"
            print(line + (f"  STOPPED: {d['failure']}" if d["failure"] else ""))
    if result["failure"]:  # the devices stopped because the log did: one line, the log's reason
        print(f"auvlink: error: {result['failure']}; recording stopped, {result['out']} replays up to its last "
              "complete chunk", file=sys.stderr)
        return 1
    failed = [n for n, d in result["devices"].items() if d["failure"]]
    if failed:
        print(f"auvlink: error: device(s) stopped early: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0
