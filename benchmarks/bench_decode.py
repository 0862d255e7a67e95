"""Decode throughput: PD0 ensembles/s against dolfyn 1.3.0 in the same run; sonar frames/s.

Run: ``auvlink bench decode --out DIR`` (or ``python benchmarks/bench_decode.py --out DIR``).
PD0 is measured on the real capture RDI_withBT.000 (../shared/data) through the framer and the
codec, per frame and through the bulk (vectorized) path; dolfyn reads the same file in its own venv.
``peers`` (docs/BENCHMARKS.md contract): seconds per read of the whole file, ours (per-frame codec, bulk)
against dolfyn, ``ratio = dolfyn / ours``. Smoke mode (``AUVLINK_BENCH_SMOKE=1``): one repeat each,
fewer sonar and gyro frames, and dolfyn only when its venv is already built.

``hostile``: every framer fed 20 MB of random garbage and of each of its worst-case patterns
(:mod:`auvlink.framing.hostile`: ':' with no line end for PD6, 0x7F7F and plausible 64 KiB headers
with bad sums for PD0, repeated sync bytes for the binary formats, ...) in 64 KiB reads, as a port
delivers them: MB/s (CPU time), peak memory of the run above the input itself (``VmHWM`` after
resetting it through ``/proc/self/clear_refs``; tracemalloc would slow the framers several fold),
and the most bytes the framer held between reads. Smoke mode: 128 KiB each.
"""

from __future__ import annotations

import re
import time
from pathlib import Path
from typing import Any

import numpy as np
from _common import best_time, script_main, smoke, table, write_json

from auvlink import formats
from auvlink.decode_file import decode_bytes
from auvlink.framing.hostile import WORST_PATTERNS as WORST_FORMATS

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "data"


def _pd0(quick: bool) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    import peer_dolfyn

    path = SHARED / "rdi" / "RDI_withBT.000"
    if not path.is_file():
        return [], {"pd0": f"skipped: {path} not found"}
    data = path.read_bytes()
    fmt = formats.get("pd0")
    n = decode_bytes(data, fmt, lambda r: None).records
    repeat = 1 if smoke() else 3 if quick else 7
    t_frame = best_time(lambda: decode_bytes(data, fmt, lambda r: None), repeat)
    rows: list[dict[str, Any]] = [{"what": "pd0 framer+decode (auvlink)", "items": n, "seconds": t_frame,
                                   "per_s": n / t_frame}]
    extra: dict[str, Any] = {}
    try:
        from auvlink.codecs import pd0_bulk
    except ImportError:
        pd0_bulk = None  # type: ignore[assignment]
    if pd0_bulk is not None:
        t_bulk = best_time(lambda: pd0_bulk.decode_file_bulk(data), repeat)
        rows.append({"what": "pd0 bulk decode (auvlink)", "items": n, "seconds": t_bulk, "per_s": n / t_bulk})
    # the smoke run (CI) never builds the peer's venv: that is pip and minutes
    peer, reason = peer_dolfyn.time_dolfyn(path, repeat=1 if smoke() else 2 if quick else 5, build=not smoke())
    if peer is None:
        extra["dolfyn"] = f"skipped: {reason}"
    else:
        rows.append({"what": f"pd0 dolfyn {peer['version']}", "items": int(peer["ensembles"]),
                     "seconds": peer["seconds"], "per_s": peer["ensembles"] / peer["seconds"]})
        for row in rows[:-1]:
            row["x_dolfyn"] = row["per_s"] / rows[-1]["per_s"]
        extra["peers"] = [{"what": f"PD0 decode of {path.name} ({n} ensembles)", "ours": row["what"],
                           "ours_s": row["seconds"], "peer": f"dolfyn {peer['version']} dolfyn.read",
                           "peer_s": peer["seconds"], "ratio": peer["seconds"] / row["seconds"]}
                          for row in rows[:-1]]
    if len(rows) >= 2 and rows[1]["what"].startswith("pd0 bulk"):
        extra.setdefault("peers", []).append(
            {"what": f"PD0 decode of {path.name} ({n} ensembles)", "ours": rows[1]["what"],
             "ours_s": rows[1]["seconds"], "peer": rows[0]["what"], "peer_s": rows[0]["seconds"],
             "ratio": rows[0]["seconds"] / rows[1]["seconds"]})
    return rows, extra


def _sonar(quick: bool) -> list[dict[str, Any]]:
    rows: list[dict[str, Any]] = []
    aris_path = SHARED / "aris" / "sample.aris"
    if aris_path.is_file():
        data = aris_path.read_bytes()
        fmt = formats.get("aris")
        n = decode_bytes(data, fmt, lambda r: None).records
        reps = 2 if smoke() else 20 if quick else 100
        t = best_time(lambda: [decode_bytes(data, fmt, lambda r: None) for _ in range(reps)], 3) / reps
        rows.append({"what": "aris file decode (48x2000)", "items": n, "seconds": t, "per_s": n / t})
    try:
        from auvlink.codecs import didson
    except ImportError:
        return rows
    rng = np.random.default_rng(0)
    image = rng.integers(0, 256, size=(512, 96), dtype=np.uint8)
    frames = [didson.encode(didson.build(image=image, frame_index=i, time=1.7e9 + i * 0.1,
                                         window_start_m=1.0, window_length_m=10.0))
              for i in range(50)]
    stream = b"".join(frames)
    fmt = formats.get("didson")
    t = best_time(lambda: decode_bytes(stream, fmt, lambda r: r.image.sum()), 3)
    rows.append({"what": "didson stream framer+decode (96x512)", "items": len(frames), "seconds": t,
                 "per_s": len(frames) / t})
    return rows


def _small(quick: bool) -> list[dict[str, Any]]:
    """Navigation formats: frames/s through framer + codec on synthetic streams."""
    rows: list[dict[str, Any]] = []
    try:
        from auvlink.codecs import dsp1760
    except ImportError:
        return rows
    frames = [dsp1760.encode(dsp1760.build(gyro=(1e-4, 2e-4, 3e-4), accel=(0.0, 0.0, -1.0),
                                           sequence=i % 128, temperature_c=25))
              for i in range(2000 if smoke() else 20000)]
    stream = b"".join(frames)
    fmt = formats.get("dsp1760")
    t = best_time(lambda: decode_bytes(stream, fmt, lambda r: None), 1 if smoke() else 3)
    rows.append({"what": "dsp1760 framer+decode", "items": len(frames), "seconds": t,
                 "per_s": len(frames) / t})
    return rows


def _vm_kib(key: str) -> int | None:
    """``VmRSS`` / ``VmHWM`` of this process in KiB (Linux), or None."""
    try:
        m = re.search(rf"^{key}:\s+(\d+) kB", Path("/proc/self/status").read_text(), re.M)
    except OSError:
        return None
    return int(m.group(1)) if m else None


def _feed_all(fmt: str, data: bytes, read: int = 1 << 16) -> dict[str, Any]:
    """Feed ``data`` to a fresh framer in ``read``-byte pieces; CPU time, peak memory, buffer high mark."""
    framer = formats.get(fmt).framer()
    try:
        Path("/proc/self/clear_refs").write_text("5")  # reset VmHWM to the current RSS
        base = _vm_kib("VmRSS")
    except OSError:
        base = None
    most = frames = 0
    t0 = time.process_time()
    for k in range(0, len(data), read):
        frames += len(framer.feed(data[k : k + read]))
        most = max(most, framer.buffered)
    frames += len(framer.flush())
    cpu = max(time.process_time() - t0, 1e-9)
    hwm = _vm_kib("VmHWM")
    return {"seconds": cpu, "mb_per_s": len(data) / cpu / 1e6, "peak_mib": None if base is None or hwm is None
            else max(0, hwm - base) / 1024, "max_buffered": most, "max_frame": framer.max_frame,
            "frames": frames, "dropped_bytes": framer.stats.dropped_bytes, "bounded": most <= framer.max_frame}


def _hostile(quick: bool) -> list[dict[str, Any]]:
    """Every framer on garbage and its worst-case patterns (see the module docstring)."""
    from auvlink.framing.hostile import garbage, pattern_stream

    size = (128 << 10) if smoke() else 20_000_000
    rows: list[dict[str, Any]] = []
    for fmt in sorted(WORST_FORMATS):
        for what, pattern in [("random garbage", None), *WORST_FORMATS[fmt]]:
            data = garbage(size) if pattern is None else pattern_stream(pattern, size)
            rows.append({"format": fmt, "input": what, "mb": size / 1e6, **_feed_all(fmt, data)})
            del data
    return rows


def run(quick: bool = True, out_dir: Path = Path("bench-out")) -> dict[str, Any]:
    t0 = time.perf_counter()
    pd0_rows, extra = _pd0(quick)
    rows = pd0_rows + _sonar(quick) + _small(quick)
    print(table(rows, ["what", "items", "seconds", "per_s", "x_dolfyn"]))
    hostile = _hostile(quick)
    print(table(hostile, ["format", "input", "mb", "seconds", "mb_per_s", "peak_mib", "max_buffered",
                          "max_frame", "bounded"]))
    peers = extra.pop("peers", [])
    for key, msg in extra.items():
        print(f"{key}: {msg}")
    result = {"rows": rows, "hostile": hostile, "peers": peers, "notes": extra, "elapsed_s": time.perf_counter() - t0}
    write_json(out_dir, "decode", result)
    return result


if __name__ == "__main__":
    script_main(run, __doc__)
