"""Chunk prefetch (the next chunk read and decompressed in a background thread): the reader yields
exactly what it yields without it, damage included, and leaves no thread behind."""

from __future__ import annotations

import threading
from pathlib import Path

import pytest

from auvlink.codecs import dsp1760
from logs_format import MissionLogReader, MissionLogWriter, chunks

T0 = 1_700_000_000_000_000_000


def frame(i: int) -> bytes:
    return dsp1760.encode(dsp1760.build((1e-5 * i, 2e-5, 0.0), (0.0, 0.0, -9.8), sequence=i))


def make_log(path: Path, compression: str = "zstd", n: int = 400) -> Path:
    with MissionLogWriter(path, chunk_size=1500, flush_interval=0, fsync=False, compression=compression) as log:
        for i in range(n):
            log("fog", "dsp1760", T0 + i * 10_000_000, frame(i))
            if i % 3 == 0:  # a second channel whose chunks overlap in time
                log("fog2", "dsp1760", T0 + i * 10_000_000 + 1, frame(i + 10_000))
    return path


def read(path: Path, prefetch: bool, **filters: int) -> tuple[list[tuple[str, int, bytes]], dict[str, object]]:
    with MissionLogReader(path, prefetch=prefetch) as log:
        got = [(m.channel, m.log_time_ns, m.data) for m in log.messages(**filters)]  # type: ignore[arg-type]
        return got, log.loss.as_dict()


def _count_prefetches(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    started: list[int] = []
    real = chunks._Prefetch

    def counting(ref: chunks.ChunkRef, fd: int, zstd: object) -> chunks._Prefetch:
        started.append(ref.offset)
        return real(ref, fd, zstd)  # type: ignore[arg-type]

    monkeypatch.setattr(chunks, "_Prefetch", counting)
    return started


@pytest.mark.parametrize("compression", ["zstd", "lz4", "none"])
def test_same_messages_with_and_without_prefetch(tmp_path: Path, compression: str,
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    path = make_log(tmp_path / "m.mcap", compression)
    started = _count_prefetches(monkeypatch)
    plain, loss_plain = read(path, prefetch=False)
    assert not started
    ahead, loss_ahead = read(path, prefetch=True)
    assert ahead == plain and loss_ahead == loss_plain
    assert len(plain) == 400 + 134
    assert [t for _, t, _ in plain] == sorted(t for _, t, _ in plain)
    with MissionLogReader(path) as log:
        n_chunks = len(log.chunks)
    assert n_chunks >= 10
    if compression == "none":
        assert not started  # nothing to decompress: read in place
    else:
        assert len(started) >= n_chunks - 2  # nearly every chunk was read ahead
    window = {"start_ns": T0 + 1_000_000_000, "end_ns": T0 + 2_500_000_000}
    assert read(path, True, **window)[0] == read(path, False, **window)[0] != []


def test_damaged_chunk_read_ahead_is_reported_like_any_other(tmp_path: Path) -> None:
    path = make_log(tmp_path / "m.mcap")
    data = bytearray(path.read_bytes())
    with MissionLogReader(path) as log:
        victims = log.chunks[2], log.chunks[5]
    for v in victims:
        data[v.data_offset + v.data_length // 2] ^= 0x20
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(data))
    plain, loss_plain = read(bad, prefetch=False)
    ahead, loss_ahead = read(bad, prefetch=True)
    assert ahead == plain and loss_ahead == loss_plain
    assert loss_ahead["bad_chunks"] == 2
    assert 0 < len(ahead) < 400 + 134


def test_no_thread_left_after_close_even_when_iteration_stops_early(tmp_path: Path) -> None:
    path = make_log(tmp_path / "m.mcap", n=2000)
    with MissionLogReader(path) as log:
        it = log.messages()
        first = [next(it) for _ in range(150)]  # a few chunks in: a prefetch is under way or done
        assert [m.log_time_ns for m in first] == sorted(m.log_time_ns for m in first)
    assert not [t for t in threading.enumerate() if t.name == "mcap-chunk-prefetch" and t.is_alive()]


def test_opener_uses_a_prefetch_only_for_its_own_chunk(tmp_path: Path) -> None:
    path = make_log(tmp_path / "m.mcap")
    with MissionLogReader(path, prefetch=False) as log:
        refs = log.chunks
        expected = {r.offset: chunks.ChunkOpener(log._f).open(r)[2] for r in refs[:6]}
        opener = chunks.ChunkOpener(log._f)
        opener.prefetch(refs[3])
        assert opener.open(refs[5])[2] == expected[refs[5].offset]  # another chunk: read in place
        opener.prefetch(refs[3])  # still the same one under way: no second thread
        assert opener.open(refs[3])[2] == expected[refs[3].offset]
        opener.prefetch(refs[4])
        opener.prefetch(refs[1])  # a new target drops the unused one
        assert opener.open(refs[4])[2] == expected[refs[4].offset]
        assert opener.open(refs[1])[2] == expected[refs[1].offset]
        opener.close()
