"""A damaged mission log loses only what the damage hit: a damaged record header (with and without a
summary), a chunk claiming a huge uncompressed size, and the loss report (structured, in seconds and
messages) in ``log info``, ``log export``, ``replay`` and ``summary.json``. Logs are written with the
project's writer (and ``auvlink sim``) and then edited byte by byte."""

from __future__ import annotations

import json
import struct
from pathlib import Path

import pytest
import zstandard

from auvlink.cli import main
from auvlink.codecs import dsp1760
from logs_format import MissionLogReader, MissionLogWriter, export_log, log_info, replay_samples
from logs_format.chunkref import MAX_CHUNK_BYTES
from logs_format.records import REC

T0 = 1_700_000_000_000_000_000
N = 150
Log = tuple[bytes, list[tuple[str, int, bytes]]]


def gyro(i: int) -> bytes:
    return dsp1760.encode(dsp1760.build((1e-5 * i, 2e-5, 0.0), (0.0, 0.0, -9.8), sequence=i))


def write_log(path: Path, compression: str = "zstd", chunk_size: int = 1500) -> list[tuple[str, int, bytes]]:
    """Two gyro channels, ~10 chunks, metadata; returns (channel, log time, frame) in write order."""
    written = []
    with MissionLogWriter(path, chunk_size=chunk_size, flush_interval=0, fsync=False,
                          compression=compression) as log:
        log.add_metadata("note", {"purpose": "damage tests"})
        for i in range(N):
            t = T0 + i * 20_000_000
            for name, dt in (("fog", 0), ("ahrs", 7)):
                log(name, "dsp1760", t + dt, gyro(i))
                written.append((name, t + dt, gyro(i)))
    return written


@pytest.fixture(scope="module")
def healthy(tmp_path_factory: pytest.TempPathFactory) -> Log:
    path = tmp_path_factory.mktemp("damage") / "healthy.mcap"
    written = write_log(path)
    return path.read_bytes(), written


def chunks_of(path: Path) -> list[tuple[int, int, int]]:
    """(record offset, record end, messages) of each chunk, from a healthy log."""
    with MissionLogReader(path) as log:
        out = []
        for ref in log.chunks:
            n = sum(1 for m in log.messages() if ref.start_ns <= m.log_time_ns <= ref.end_ns)
            out.append((ref.offset, ref.data_offset + ref.data_length, n))
        return out


def read_all(path: Path) -> list[tuple[str, int, bytes]]:
    with MissionLogReader(path) as log:
        return [(m.channel, m.log_time_ns, m.data) for m in log.messages()]


def put(path: Path, data: bytes | bytearray) -> Path:
    path.write_bytes(bytes(data))
    return path


def no_summary(data: bytes) -> bytes:
    """The log as a writer killed before close leaves it: everything before the DataEnd record."""
    pos = 8
    while True:
        op, length = REC.unpack_from(data, pos)
        if op == 0x0F:
            return data[:pos]
        pos += 9 + length


def test_damaged_first_chunk_opcode_log_info_export_replay(tmp_path: Path, healthy: Log,
                                                           capsys: pytest.CaptureFixture[str]) -> None:
    data, written = healthy
    full = put(tmp_path / "full.mcap", data)
    first = chunks_of(full)[0][0]
    bad = bytearray(data)
    bad[first] = 0x55  # the opcode of the first chunk
    path = put(tmp_path / "bad.mcap", bad)
    assert main(["log", "info", str(path), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["message_count"] == len(written) and info["channels"]["fog"]["count"] == N
    assert info["chunk_count"] == len(chunks_of(full))
    assert read_all(path) == sorted(written, key=lambda w: w[1])
    result = export_log(path, tmp_path / "export", png=False)
    assert result.csv_rows == {"fog": N, "ahrs": N}
    assert len(list(replay_samples(path))) == len(written)


def test_damaged_chunk_header_the_summary_index_finds_it(tmp_path: Path, healthy: Log) -> None:
    """Opcode and length destroyed: only the summary knows where the chunk ends; its CRC checks the data."""
    data, written = healthy
    first = chunks_of(put(tmp_path / "full.mcap", data))[0][0]
    bad = bytearray(data)
    bad[first : first + 9] = b"\xee" * 9
    path = put(tmp_path / "bad.mcap", bad)
    with MissionLogReader(path) as log:
        got = [(m.channel, m.log_time_ns, m.data) for m in log.messages()]
        assert log.loss.summary_index and log.complete and not log.loss.lossy
    assert got == sorted(written, key=lambda w: w[1])


def test_no_summary_resyncs_past_a_damaged_chunk(tmp_path: Path, healthy: Log) -> None:
    data, written = healthy
    chunks = chunks_of(put(tmp_path / "full.mcap", data))
    cut = no_summary(data)
    for k in (0, 3):  # the first chunk (it defined the channels) and one in the middle
        start, end, n_lost = chunks[k]
        bad = bytearray(cut)
        bad[start : start + 9] = b"\xee" * 9  # opcode and length: the walk cannot step over it
        bad[start + 40 : start + 60] = bytes(20)
        path = put(tmp_path / f"bad{k}.mcap", bad)
        with MissionLogReader(path) as log:
            got = [(m.channel, m.log_time_ns, m.data) for m in log.messages()]
            loss = log.loss
        assert len(got) == len(written) - n_lost, k
        assert set(got) <= set(written)
        assert not loss.complete and loss.state == "damaged_and_cut_off"
        (span,) = [s for s in loss.spans if s.kind == "unreadable"]
        assert span.offset == start and span.length == end - start
        assert span.messages == n_lost == loss.messages_lost  # from the chunk's message index records
        assert span.seconds == pytest.approx((n_lost / 2 - 1) * 0.02, abs=0.0101)


def test_an_index_record_turned_message_is_not_read_as_one(tmp_path: Path, healthy: Log) -> None:
    """One bit turns a message index record (0x07) into a top-level message (0x05): nothing verifies such
    a record, and a file of chunks holds none, so it is skipped and reported, not read as a frame."""
    data, written = healthy
    end = chunks_of(put(tmp_path / "full.mcap", data))[2][1]
    assert data[end] == 0x07
    bad = bytearray(data)
    bad[end] ^= 0x02
    with MissionLogReader(put(tmp_path / "bad.mcap", bad)) as log:
        got = [(m.channel, m.log_time_ns, m.data) for m in log.messages()]
        assert [s.kind for s in log.loss.spans] == ["unreadable"] and log.loss.spans[0].offset == end
    assert got == sorted(written, key=lambda w: w[1])


def test_a_chunk_claiming_a_terabyte_is_reported_bad_and_the_rest_read(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Legal zstd frames without a content size; one chunk's header claims 1 TB uncompressed."""
    import mcap.writer

    no_size = zstandard.ZstdCompressor(write_content_size=False)
    monkeypatch.setattr(mcap.writer.zstandard, "compress", no_size.compress)
    path = tmp_path / "huge.mcap"
    written = write_log(path)
    assert zstandard.frame_content_size(path.read_bytes()[chunks_of(path)[2][0] + 9 + 44:][:64]) == -1
    start, _, n_lost = chunks_of(path)[2]
    data = bytearray(path.read_bytes())
    (usize,) = struct.unpack_from("<Q", data, start + 9 + 16)
    for claim in (1 << 40, MAX_CHUNK_BYTES + 1, 200_000):  # over the ceiling; more than the bytes can hold
        struct.pack_into("<Q", data, start + 9 + 16, claim)
        bad = put(tmp_path / "bad.mcap", data)
        with MissionLogReader(bad) as log:
            got = [(m.channel, m.log_time_ns, m.data) for m in log.messages()]
            loss = log.loss
        assert len(got) == len(written) - n_lost and set(got) <= set(written)
        assert loss.bad_chunks == 1 and loss.messages_lost == n_lost and loss.state == "damaged"
        assert "claims" in loss.spans[0].reason
        info = log_info(bad)
        assert info["message_count"] == len(written) - n_lost and info["loss"]["damaged_chunks"] == 1
    struct.pack_into("<Q", data, start + 9 + 16, usize - 1)  # a chunk holding one byte more than it claims
    with MissionLogReader(put(tmp_path / "bad.mcap", data)) as log:
        assert sum(1 for _ in log.messages()) == len(written) - n_lost
        assert "size mismatch" in log.loss.spans[0].reason


def test_lz4_chunk_claim_is_bounded(tmp_path: Path) -> None:
    path = tmp_path / "lz4.mcap"
    written = write_log(path, compression="lz4")
    start, _, n_lost = chunks_of(path)[1]
    data = bytearray(path.read_bytes())
    struct.pack_into("<Q", data, start + 9 + 16, 1 << 40)
    with MissionLogReader(put(tmp_path / "bad.mcap", data)) as log:
        assert sum(1 for _ in log.messages()) == len(written) - n_lost
        assert log.loss.bad_chunks == 1


def test_log_info_prints_what_was_lost(tmp_path: Path, healthy: Log, capsys: pytest.CaptureFixture[str]) -> None:
    data, written = healthy
    chunks = chunks_of(put(tmp_path / "full.mcap", data))
    start, end, n_lost = chunks[4]
    bad = bytearray(data)
    bad[start + 100 : start + 140] = bytes(40)  # inside the compressed records: the CRC/zstd check fails
    path = put(tmp_path / "bad.mcap", bad)
    assert main(["log", "info", str(path)]) == 0
    text = capsys.readouterr().out
    assert f"{len(written) - n_lost} messages" in text
    assert f"damaged: 1 damaged chunk(s) skipped ({end - start} bytes" in text and f"{n_lost} messages lost" in text
    assert main(["log", "info", str(path), "--json"]) == 0
    loss = json.loads(capsys.readouterr().out)["loss"]
    assert loss["state"] == "damaged" and loss["damaged_chunks"] == 1 and loss["messages_lost"] == n_lost
    assert loss["messages_lost_exact"] and loss["cut_off"] is None and loss["bytes_skipped"] == end - start
    (span,) = loss["spans"]
    assert span["kind"] == "damaged_chunk" and span["offset"] == start and span["messages"] == n_lost
    assert loss["seconds_lost"] == pytest.approx(span["seconds"]) and span["seconds"] > 0


def test_cut_off_log_reports_the_tail(tmp_path: Path, healthy: Log, capsys: pytest.CaptureFixture[str]) -> None:
    data, written = healthy
    chunks = chunks_of(put(tmp_path / "full.mcap", data))
    start, end, _ = chunks[-3]
    cut = (start + end) // 2
    path = put(tmp_path / "cut.mcap", data[:cut])
    assert read_all(path) == sorted(written, key=lambda w: w[1])[: sum(n for _, e, n in chunks if e <= cut)]
    assert main(["log", "info", str(path), "--json"]) == 0
    loss = json.loads(capsys.readouterr().out)["loss"]
    assert loss["state"] == "cut_off" and loss["cut_off"]["offset"] == start
    assert loss["cut_off"]["bytes"] == cut - start and loss["cut_off"]["seconds"] > 0
    assert loss["lost_bytes"] == loss["cut_off"]["bytes"]


# -- replay of a simulated mission: summary.json's structured loss report and the warning line -------------
@pytest.fixture(scope="module")
def sim_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from live_helpers import SCENE

    from auvlink.sim.mission import simulate_to_log
    from auvlink.sim.scene import loads_scene

    path = tmp_path_factory.mktemp("simdamage") / "mission.mcap"
    simulate_to_log(loads_scene(SCENE), path, progress=False, duration=12.0)  # two chunks
    return path


@pytest.mark.slow
def test_replay_of_a_damaged_simulated_log(tmp_path: Path, sim_log: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    with MissionLogReader(sim_log) as log:
        ref = log.chunks[0]
        total = sum(1 for _ in log.messages())
    data = bytearray(sim_log.read_bytes())
    data[ref.offset] = 0x55  # the opcode of the first chunk
    data[ref.data_offset + 1000 : ref.data_offset + 1100] = bytes(100)  # and its data: the chunk is lost
    bad = put(tmp_path / "bad.mcap", data)
    out = tmp_path / "out"
    assert main(["replay", str(bad), "--out", str(out), "--no-classify", "--quiet"]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    warning = [line for line in err if "warning" in line]
    assert len(warning) == 1 and str(bad) in warning[0] and "messages lost" in warning[0], err
    loss = json.loads((out / "summary.json").read_text())["log_loss"]
    assert isinstance(loss, dict) and loss["state"] == "damaged" and loss["damaged_chunks"] == 1
    assert 0 < loss["messages_lost"] < total and loss["seconds_lost"] > 0
    assert loss["summary"].startswith("damaged: 1 damaged chunk(s) skipped")
    report = (out / "report.html").read_text()
    assert "Log integrity: damaged: 1 damaged chunk(s) skipped" in report and "<td>damaged_chunk</td>" in report
    assert "LossReport(" not in report
    assert main(["replay", str(sim_log), "--out", str(tmp_path / "ok"), "--no-classify", "--no-report",
                 "--quiet"]) == 0
    assert "warning" not in capsys.readouterr().err
    clean = json.loads((tmp_path / "ok" / "summary.json").read_text())["log_loss"]
    assert clean["state"] == "complete" and clean["messages_lost"] == 0 and clean["spans"] == []
