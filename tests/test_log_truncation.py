"""Damaged logs: cut at many byte offsets (mid-chunk included), a writer killed with SIGKILL, a
flipped bit, a zero-filled tail. Reading yields everything of the whole chunks, reports the loss,
and never raises."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from auvlink.atomic import partial_path
from auvlink.codecs import dsp1760
from logs_format import MissionLogReader, MissionLogWriter, log_info, replay_samples

T0 = 1_700_000_000_000_000_000


def frame(i: int) -> bytes:
    return dsp1760.encode(dsp1760.build((1e-5 * i, 2e-5, 0.0), (0.0, 0.0, -9.8), sequence=i))


@pytest.fixture(scope="module")
def small_log(tmp_path_factory: pytest.TempPathFactory) -> tuple[bytes, list[tuple[int, bytes]]]:
    """~6 kB log, several small chunks, metadata between them."""
    path = tmp_path_factory.mktemp("trunc") / "small.mcap"
    written: list[tuple[int, bytes]] = []
    with MissionLogWriter(path, chunk_size=600, flush_interval=0, fsync=False) as log:
        for i in range(120):
            t = T0 + i * 10_000_000
            log("fog", "dsp1760", t, frame(i))
            written.append((t, frame(i)))
            if i == 60:
                log.add_metadata("note", {"i": i})
    return path.read_bytes(), written


@pytest.mark.slow
def test_cut_at_every_97_bytes(tmp_path: Path, small_log: tuple[bytes, list[tuple[int, bytes]]]) -> None:
    data, written = small_log
    with MissionLogReader(_write(tmp_path / "full.mcap", data)) as full:
        chunk_ends = sorted((c.data_offset + c.data_length, c.end_ns) for c in full.chunks)
        assert len(chunk_ends) >= 8
    cut_path = tmp_path / "cut.mcap"
    mid_chunk_cuts = 0
    for cut in range(0, len(data), 97):
        _write(cut_path, data[:cut])
        with MissionLogReader(cut_path) as log:
            got = [(m.log_time_ns, m.data) for m in log.messages()]
            loss = log.loss
        whole = [end_t for end, end_t in chunk_ends if end <= cut]
        # exactly the messages of the chunks that lie whole before the cut, in order
        n_expected = sum(1 for t, _ in written if whole and t <= whole[-1])
        assert got == written[:n_expected], cut
        assert not loss.complete and loss.truncated
        assert loss.valid_bytes + loss.lost_bytes == cut
        assert loss.last_time_ns == (whole[-1] if whole else None)
        if any(c.offset < cut < c.data_offset + c.data_length for c in full.chunks):
            mid_chunk_cuts += 1
            assert loss.lost_bytes > 0
        assert loss.describe()
    assert mid_chunk_cuts > 20


Small = tuple[bytes, list[tuple[int, bytes]]]


@pytest.mark.slow
def test_cut_logs_replay_and_info_never_raise(tmp_path: Path, small_log: Small) -> None:
    data, written = small_log
    cut_path = tmp_path / "cut.mcap"
    for cut in range(0, len(data), 389):
        _write(cut_path, data[:cut])
        samples = list(replay_samples(cut_path))
        assert [s.raw for s in samples] == [r for _, r in written[: len(samples)]]
        info = log_info(cut_path)
        assert info["complete"] is False
        assert info["message_count"] == len(samples)


def test_flipped_bit_skips_one_chunk(tmp_path: Path, small_log: Small) -> None:
    data, written = small_log
    with MissionLogReader(_write(tmp_path / "full.mcap", data)) as full:
        victim = full.chunks[3]
        n_victim = sum(1 for t, _ in written if victim.start_ns <= t <= victim.end_ns)
    bad = bytearray(data)
    bad[victim.data_offset + victim.data_length // 2] ^= 0x10
    with MissionLogReader(_write(tmp_path / "bad.mcap", bytes(bad))) as log:
        got = [m.data for m in log.messages()]
        assert log.complete
        assert log.loss.bad_chunks == 1 and log.loss.lossy
        assert len(got) == len(written) - n_victim
        assert "damaged" in log.loss.describe()
        list(log.messages())  # a second pass counts the same chunk once
        assert log.loss.bad_chunks == 1


def test_zero_filled_tail(tmp_path: Path, small_log: tuple[bytes, list[tuple[int, bytes]]]) -> None:
    """Power loss on some file systems leaves zeros after the last write."""
    data, written = small_log
    cut = len(data) // 2
    with MissionLogReader(_write(tmp_path / "z.mcap", data[:cut] + bytes(4096))) as log:
        got = [(m.log_time_ns, m.data) for m in log.messages()]
        assert 0 < len(got) < len(written)
        assert got == written[: len(got)]
        assert not log.complete and log.loss.lossy
        # the cut chunk now seems whole (zeros fill it) but fails its check; the rest is zeros
        assert log.loss.lost_bytes + log.loss.bad_chunk_bytes >= 4096


WRITER = textwrap.dedent("""
    import sys, time
    from auvlink.codecs import dsp1760
    from logs_format import MissionLogWriter
    log = MissionLogWriter(sys.argv[1], flush_interval=0.05, chunk_size=1 << 20)
    i = 0
    t0 = time.time_ns()
    while True:
        raw = dsp1760.encode(dsp1760.build((i * 1e-6, 0.0, 0.0), (0.0, 0.0, -9.8), sequence=i))
        log("fog", "dsp1760", t0 + i * 1_000_000, raw)
        if i % 50 == 0:
            log("sonar", "didson", t0 + i * 1_000_000, bytes([i % 256]) * 5000)
        i += 1
        if i == 200:
            print("running", flush=True)
        time.sleep(0.0005)
""")


def test_sigkill_mid_write_replays(tmp_path: Path) -> None:
    path = tmp_path / "killed.mcap"
    proc = subprocess.Popen([sys.executable, "-c", WRITER, str(path)], stdout=subprocess.PIPE,
                            env={**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])})
    try:
        assert proc.stdout is not None
        assert proc.stdout.readline().strip() == b"running"
        time.sleep(0.6)
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=10)
        if proc.stdout is not None:
            proc.stdout.close()
    assert proc.returncode == -signal.SIGKILL
    assert not path.exists()  # renamed only when closed: a killed writer leaves killed.mcap.partial
    path = partial_path(path)
    with MissionLogReader(path) as log:
        msgs = list(log.messages(channels=["fog"]))
        assert not log.complete
        assert log.loss.last_time_ns is not None
    assert len(msgs) >= 200  # at most ~0.05 s + one chunk of frames lost
    seqs = [m.sequence for m in msgs]
    assert seqs == list(range(len(seqs)))  # nothing missing before the loss
    samples = list(replay_samples(path, channels=["fog"]))
    assert len(samples) == len(msgs)
    assert [s.record.sequence for s in samples] == [i % 128 for i in range(len(samples))]


def _write(path: Path, data: bytes) -> Path:
    path.write_bytes(data)
    return path
