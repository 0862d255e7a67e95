"""Mission log throughput: record and replay a synthetic survey at sonar rate; peak memory.

Run: ``auvlink bench log --out DIR [--full]`` (or ``python benchmarks/bench_log.py --out DIR [--full]``).

The mission: DIDSON-class sonar frames at 10 fps (1024-byte header + 96 x 512 image = 50176 B,
uniform random images, so they do not compress: the worst case for the disk), DVL PD0 at 5 Hz,
FOG DSP-1760 at 100 Hz, Digiquartz pressure at 10 Hz and navigation CAN frames at 20 Hz, all
built by the codecs' own encoders (random bytes of the right size where a codec is missing).
``--full``: 35 minutes of mission (the 30-minute goal, long enough for a log over 1 GB); quick: 3
minutes; smoke (``AUVLINK_BENCH_SMOKE=1``): 30 s.

* record: every frame through :class:`MissionLogWriter` (zstd, 4 MiB chunks, 1 s flush
  interval, fsync) as fast as it takes them; x real time = mission time / writer time (frame
  generation not counted; wall time including it is reported too). Goal >= 10x.
* replay: :class:`Replay` fast mode, read + framer + decode of every frame; goal >= 50x. Measured
  again with the framers' one-frame fast path off and with chunk prefetch off (the ``peers`` rows),
  and decoding only the channels a pipeline stage consumes (as ``auvlink replay`` does: no CAN).
* read: the reader alone (raw frames, time-ordered merge).
* wall time and CPU time are both reported: on a shared machine the CPU-time figure is the steadier.
* memory: peak resident set of this process while recording and replaying, sampled from
  /proc/self/statm every 20 ms (page cache not included). Goal < 500 MB for a log >= 1 GB.
"""

from __future__ import annotations

import argparse
import os
import shutil
import tempfile
import threading
import time
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
from _common import smoke, table, write_json

from auvlink.pipeline.nav_inputs import CONSUMED_FORMATS
from logs_format import MissionLogReader, MissionLogWriter, Replay

FULL_S, QUICK_S, SMOKE_S = 2100.0, 180.0, 30.0
T0 = 1_700_000_000_000_000_000
TICK_NS = 10_000_000  # 100 Hz base tick
SONAR_BYTES = 1024 + 96 * 512
SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "data"


class RssPeak:
    """Samples this process's resident set size in a thread; ``peak_mb`` after the block."""

    def __init__(self, period: float = 0.02) -> None:
        self.period = period
        self.peak = 0
        self._stop = threading.Event()
        self._page = os.sysconf("SC_PAGE_SIZE")
        self._thread = threading.Thread(target=self._run, daemon=True)

    def rss(self) -> int:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * self._page

    def _run(self) -> None:
        while not self._stop.is_set():
            self.peak = max(self.peak, self.rss())
            self._stop.wait(self.period)

    def __enter__(self) -> RssPeak:
        self.peak = self.rss()
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()
        self.peak = max(self.peak, self.rss())

    @property
    def peak_mb(self) -> float:
        return self.peak / 1e6


class Sources:
    """Frame pools and the per-frame sonar encoder; ``notes`` says what was synthetic."""

    def __init__(self, seed: int = 0) -> None:
        rng = np.random.default_rng(seed)
        self.notes: dict[str, str] = {}
        # uniform random images: the worst case for compression (real sonar images compress 2-4x);
        # 256 of them, more than fit in one chunk, so a chunk never holds the same image twice
        self.images = [rng.integers(0, 256, size=(512, 96), dtype=np.uint8) for _ in range(256)]
        self.sonar_format = "didson"
        try:
            from auvlink.codecs import didson

            self._didson: Any = didson
        except ImportError:
            self._didson = None
            self._rand = [rng.integers(0, 256, SONAR_BYTES, dtype=np.uint8).tobytes() for _ in range(64)]
            self.notes["sonar"] = "didson codec missing: random bytes of 50176 B (decode errors in replay)"
        self.fog = self._fog()
        self.dvl = self._dvl(rng)
        self.pressure = self._pressure()
        self.can = self._can()

    def sonar(self, i: int, t_ns: int) -> bytes:
        if self._didson is None:
            return self._rand[i % len(self._rand)]
        d = self._didson
        image = self.images[i % len(self.images)]
        return bytes(d.encode(d.build(image=image, frame_index=i, time=t_ns * 1e-9,
                                      window_start_m=1.0, window_length_m=10.0)))

    def _fog(self) -> list[bytes]:
        from auvlink.codecs import dsp1760

        return [dsp1760.encode(dsp1760.build((1e-4 * np.sin(i / 50), 2e-5, -1e-4), (0.1, 0.0, -9.80665),
                                             sequence=i)) for i in range(1024)]

    def _dvl(self, rng: np.random.Generator) -> list[bytes]:
        from auvlink import formats

        path = SHARED / "rdi" / "RDI_withBT.000"
        if path.is_file():
            frames = formats.get("pd0").framer().feed(path.read_bytes())
            if frames:
                return frames
        self.notes["dvl"] = f"{path} missing: random bytes of 581 B"
        return [rng.integers(0, 256, 581, dtype=np.uint8).tobytes() for _ in range(64)]

    def _pressure(self) -> list[bytes]:
        from auvlink.codecs import paro

        return [paro.encode(paro.build_reading(101325.0 + 1e4 * (20 + 0.01 * i))) for i in range(100)]

    def _can(self) -> list[bytes]:
        try:
            from auvlink.codecs import can_nav

            return [can_nav.encode(can_nav.build(name)) for name in can_nav.message_names()]
        except ImportError:
            self.notes["can"] = "can codec missing: no CAN channel"
            return []

    def events(self, mission_s: float) -> Iterator[tuple[str, str, int, bytes]]:
        """(device, format, t_host_ns, raw) in time order over the mission."""
        for k in range(round(mission_s * 1e9 / TICK_NS)):
            t = T0 + k * TICK_NS
            yield "fog", "dsp1760", t, self.fog[k % len(self.fog)]
            if self.can and k % 5 == 1:
                yield "can", "can", t + 1_000_000, self.can[(k // 5) % len(self.can)]
            if k % 10 == 2:
                yield "pressure", "paro", t + 2_000_000, self.pressure[(k // 10) % len(self.pressure)]
            if k % 10 == 3:
                yield "sonar", self.sonar_format, t + 3_000_000, self.sonar(k // 10, t + 3_000_000)
            if k % 20 == 4:
                yield "dvl", "pd0", t + 4_000_000, self.dvl[(k // 20) % len(self.dvl)]


def _record(path: Path, mission_s: float, src: Sources) -> dict[str, Any]:
    frames = raw_bytes = 0
    writer_s = writer_cpu = 0.0
    clock, cpu = time.perf_counter, time.process_time
    with RssPeak() as mem:
        t_wall = clock()
        t, c = clock(), cpu()
        log = MissionLogWriter(path)
        writer_s, writer_cpu = writer_s + clock() - t, writer_cpu + cpu() - c
        for device, fmt, t_ns, raw in src.events(mission_s):
            t, c = clock(), cpu()
            log(device, fmt, t_ns, raw)
            writer_s, writer_cpu = writer_s + clock() - t, writer_cpu + cpu() - c
            frames += 1
            raw_bytes += len(raw)
        t, c = clock(), cpu()
        log.close()
        writer_s, writer_cpu = writer_s + clock() - t, writer_cpu + cpu() - c
        wall = clock() - t_wall
    size = path.stat().st_size
    return {"stage": "record", "mission_s": mission_s, "frames": frames, "raw_MB": raw_bytes / 1e6,
            "log_MB": size / 1e6, "seconds": writer_s, "x_realtime": mission_s / writer_s,
            "cpu_s": writer_cpu, "x_realtime_cpu": mission_s / writer_cpu,
            "wall_with_generation_s": wall, "peak_rss_MB": mem.peak_mb, "goal": ">= 10x",
            "ok": mission_s / writer_s >= 10}


class GeneralPathReplay(Replay):
    """Replay with the framers' one-whole-frame fast path switched off (every message through
    ``Framer._extract``): the reference the fast path is measured against in the same run."""

    def decoder(self, msg: Any) -> Any:
        dec = super().decoder(msg)
        if dec is not None:
            dec.framer._whole = lambda data: None  # type: ignore[method-assign]
        return dec


def _replay(path: Path, mission_s: float, general_path: bool = False, prefetch: bool = True,
            formats: Iterable[str] | None = None) -> dict[str, Any]:
    n = errors = 0
    with RssPeak() as mem:
        t0, c0 = time.perf_counter(), time.process_time()
        with (GeneralPathReplay if general_path else Replay)(path, formats=formats) as rep:
            rep.reader.prefetch = prefetch
            for _ in rep.samples():
                n += 1
            errors = sum(d.stats.decode_errors for d in rep.decoders.values())
            framer_drops = sum(d.framer.stats.dropped_bytes for d in rep.decoders.values())
        dt, dc = time.perf_counter() - t0, time.process_time() - c0
    stage = ("replay, framer general path" if general_path else "replay, no chunk prefetch" if not prefetch
             else "replay, the pipeline's channels only" if formats is not None else "replay (read+frame+decode)")
    return {"stage": stage, "mission_s": mission_s, "frames": n, "seconds": dt,
            "x_realtime": mission_s / dt, "cpu_s": dc, "x_realtime_cpu": mission_s / dc,
            "peak_rss_MB": mem.peak_mb, "decode_errors": errors,
            "framer_dropped_bytes": framer_drops, "goal": ">= 50x", "ok": mission_s / dt >= 50}


def _read(path: Path, mission_s: float) -> dict[str, Any]:
    n = 0
    with RssPeak() as mem:
        t0, c0 = time.perf_counter(), time.process_time()
        with MissionLogReader(path) as log:
            for _ in log.messages():
                n += 1
            loss = log.loss.describe()
        dt, dc = time.perf_counter() - t0, time.process_time() - c0
    return {"stage": "read (raw frames)", "mission_s": mission_s, "frames": n, "seconds": dt,
            "x_realtime": mission_s / dt, "cpu_s": dc, "x_realtime_cpu": mission_s / dc,
            "peak_rss_MB": mem.peak_mb, "log_state": loss}


def run(quick: bool = True, out_dir: Path = Path("bench-out"), keep_log: bool = False) -> dict[str, Any]:
    mission_s = SMOKE_S if smoke() else QUICK_S if quick else FULL_S
    out_dir.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix="bench-log-", dir=out_dir))
    path = work / "mission.mcap"
    t0 = time.perf_counter()
    try:
        src = Sources()
        base_mb = RssPeak().rss() / 1e6
        rows = [_record(path, mission_s, src)]
        notes = dict(src.notes)
        del src
        with MissionLogReader(path) as log:  # warm up: import every codec before anything is timed
            end = (log.start_ns or 0) + 2_000_000_000
        with Replay(path, end_ns=end) as rep:
            for _ in rep.samples():
                pass
        rows.append(_read(path, mission_s))
        rows.append(_replay(path, mission_s))
        rows.append(_replay(path, mission_s, general_path=True))
        rows.append(_replay(path, mission_s, prefetch=False))
        rows.append(_replay(path, mission_s, formats=CONSUMED_FORMATS))  # what auvlink replay decodes
        log_bytes = path.stat().st_size
    finally:
        if not keep_log:
            shutil.rmtree(work, ignore_errors=True)
    peak = max(r["peak_rss_MB"] for r in rows)
    memory_ok = peak < 500
    print(table(rows, ["stage", "mission_s", "frames", "log_MB", "seconds", "x_realtime", "x_realtime_cpu",
                       "peak_rss_MB", "ok"]))
    load = os.getloadavg()[0]
    print(f"load average {load:.2f} on {os.cpu_count()} cores (x_realtime_cpu: CPU time, less sensitive to "
          "other processes)")
    for key, note in notes.items():
        print(f"{key}: {note}")
    print(f"log {log_bytes / 1e9:.3f} GB; peak RSS {peak:.0f} MB (process baseline {base_mb:.0f} MB) "
          f"-> {'under' if memory_ok else 'OVER'} 500 MB")
    result = {
        "quick": quick, "mission_s": mission_s, "rows": rows, "log_bytes": log_bytes,
        "record_x_realtime": rows[0]["x_realtime"], "replay_x_realtime": rows[2]["x_realtime"],
        "read_x_realtime": rows[1]["x_realtime"], "peak_rss_MB": peak, "baseline_rss_MB": base_mb,
        "memory_ok": memory_ok, "load_average_1min": os.getloadavg()[0], "log_over_1GB": log_bytes >= 1e9,
        "notes": notes,
        "peers": [{"what": "replay read+frame+decode of the whole log (CPU s)", "ours": "framer fast path",
                   "ours_s": rows[2]["cpu_s"], "peer": "framer general path (Framer._whole off)",
                   "peer_s": rows[3]["cpu_s"], "ratio": rows[3]["cpu_s"] / rows[2]["cpu_s"]},
                  {"what": "replay read+frame+decode of the whole log (wall s)", "ours": "next chunk prefetched in "
                   "a thread", "ours_s": rows[2]["seconds"], "peer": "no prefetch", "peer_s": rows[4]["seconds"],
                   "ratio": rows[4]["seconds"] / rows[2]["seconds"]}],
        "elapsed_s": time.perf_counter() - t0,
    }
    write_json(out_dir, "log", result)
    return result


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=Path("bench-out"))
    ap.add_argument("--full", action="store_true")
    ap.add_argument("--keep-log", action="store_true")
    a = ap.parse_args()
    run(quick=not a.full, out_dir=a.out, keep_log=a.keep_log)
