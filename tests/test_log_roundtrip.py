"""Mission log write -> read: raw frames bit for bit, times, time-ordered merge, filters, metadata,
attachments, JSON channels, compression, flush interval and several writer threads."""

from __future__ import annotations

import json
import threading
import time
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from mcap.reader import make_reader

from auvlink.codecs import dsp1760
from auvlink.config import loads_config
from logs_format import LogError, MissionLogReader, MissionLogWriter, read_messages
from logs_format.schemas import (
    DETECTION_SCHEMA,
    DETECTION_SCHEMA_NAME,
    POSE_SCHEMA,
    POSE_SCHEMA_NAME,
    detection_message,
    pose_message,
    validate,
)

T0 = 1_700_000_000_000_000_000


def gyro_frame(i: int) -> bytes:
    return dsp1760.encode(dsp1760.build((1e-4 * i, 0.0, -1e-4), (0.0, 0.0, -9.80665), sequence=i))


def write_mission(path: Path, n: int = 300, **kw: object) -> list[tuple[str, str, int, bytes]]:
    """Gyro at 100 Hz, a byte-blob 'dvl' at 5 Hz: returns what was written."""
    frames: list[tuple[str, str, int, bytes]] = []
    for i in range(n):
        frames.append(("gyro", "dsp1760", T0 + i * 10_000_000, gyro_frame(i)))
        if i % 20 == 0:
            blob = bytes(range(256)) * 2 + bytes([i % 256])
            frames.append(("dvl", "pd0", T0 + i * 10_000_000 + 3_000_000, blob))
    with MissionLogWriter(path, flush_interval=0, **kw) as log:  # type: ignore[arg-type]
        for device, fmt, t, raw in frames:
            log(device, fmt, t, raw)
    return frames


@pytest.mark.parametrize("compression", ["zstd", "lz4", "none"])
def test_round_trip_bit_exact(tmp_path: Path, compression: str) -> None:
    path = tmp_path / "m.mcap"
    frames = write_mission(path, compression=compression, chunk_size=4096)
    with MissionLogReader(path) as log:
        got = list(log.messages())
        assert log.complete and not log.loss.lossy
        assert len(log.chunks) > 3
        assert {c.compression for c in log.chunks} == {"" if compression == "none" else compression}
        assert set(log.channels) == {"gyro", "dvl"}
        assert log.channels["gyro"].message_encoding == "kvh.dsp1760"
        assert log.channels["gyro"].schema_name == "auvlink.kvh.dsp1760"
        assert log.channels["gyro"].schema_encoding == "kvh.dsp1760"
        assert log.channels["gyro"].format == "dsp1760"
        assert log.duration_s == pytest.approx((frames[-1][2] - T0) * 1e-9)
    expect = sorted(frames, key=lambda f: f[2])
    assert [(m.channel, m.format, m.log_time_ns, m.data) for m in got] == expect
    assert all(m.t_sensor_ns is None for m in got)
    gyro_seq = [m.sequence for m in got if m.channel == "gyro"]
    assert gyro_seq == list(range(len(gyro_seq)))


def test_standard_mcap_reader_agrees(tmp_path: Path) -> None:
    """The file is plain MCAP: the mcap package's own reader sees the same messages."""
    path = tmp_path / "m.mcap"
    frames = write_mission(path, chunk_size=4096)
    with open(path, "rb") as f:
        reader = make_reader(f)
        got = [(ch.topic, msg.log_time, msg.data) for _, ch, msg in reader.iter_messages(log_time_order=True)]
        summary = reader.get_summary()
    assert summary is not None and summary.statistics is not None
    assert summary.statistics.message_count == len(frames)
    assert sorted(got, key=lambda g: g[1]) == sorted(((d, t, r) for d, _, t, r in frames), key=lambda g: g[1])


def test_merge_orders_by_log_time_across_channels_and_threads(tmp_path: Path) -> None:
    """Frames arrive out of order from several threads; the reader yields them in time order."""
    path = tmp_path / "m.mcap"
    n_threads, per_thread = 4, 400
    with MissionLogWriter(path, chunk_size=2048, flush_interval=0.05) as log:
        def produce(k: int) -> None:
            for i in range(per_thread):
                # each device's own times increase; devices interleave arbitrarily
                log(f"dev{k}", "dsp1760", T0 + i * 1_000_000 + k * 137, gyro_frame(i))
        threads = [threading.Thread(target=produce, args=(k,)) for k in range(n_threads)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        assert log.counts() == {f"dev{k}": per_thread for k in range(n_threads)}
    msgs = list(read_messages(path))
    times = [m.log_time_ns for m in msgs]
    assert len(msgs) == n_threads * per_thread
    assert times == sorted(times)
    for k in range(n_threads):
        mine = [m for m in msgs if m.channel == f"dev{k}"]
        assert [m.data for m in mine] == [gyro_frame(i) for i in range(per_thread)]
        assert [m.sequence for m in mine] == list(range(per_thread))


def test_out_of_order_chunks_merge(tmp_path: Path) -> None:
    """A late frame (earlier time, later chunk) still comes out in time order."""
    path = tmp_path / "m.mcap"
    with MissionLogWriter(path, chunk_size=100, flush_interval=0) as log:
        for t in (50, 60, 70, 10, 80, 20, 90):
            log("a" if t % 20 else "b", "dsp1760", T0 + t, gyro_frame(t))
    assert [m.log_time_ns - T0 for m in read_messages(path)] == [10, 20, 50, 60, 70, 80, 90]


def test_filters_channel_and_time(tmp_path: Path) -> None:
    path = tmp_path / "m.mcap"
    frames = write_mission(path, chunk_size=3000)
    lo, hi = T0 + 500_000_000, T0 + 1_500_000_000
    got = list(read_messages(path, channels=["dvl"], start_ns=lo, end_ns=hi))
    expect = [(t, r) for d, _, t, r in frames if d == "dvl" and lo <= t < hi]
    assert [(m.log_time_ns, m.data) for m in got] == sorted(expect)
    assert len(expect) == 5
    assert list(read_messages(path, channels=["nothing"])) == []
    assert len(list(read_messages(path, start_ns=T0 + 10**12))) == 0


def test_sensor_time_is_publish_time(tmp_path: Path) -> None:
    path = tmp_path / "m.mcap"
    with MissionLogWriter(path) as log:
        log("dvl", "pd0", T0 + 5, b"abc", t_sensor_ns=T0 - 1000)
        log("dvl", "pd0", T0 + 6, b"abd")
    a, b = read_messages(path)
    assert (a.t_sensor_ns, a.publish_time_ns, b.t_sensor_ns) == (T0 - 1000, T0 - 1000, None)


def test_metadata_attachments_and_config(tmp_path: Path) -> None:
    config = loads_config(
        '[vehicle]\nname = "auv7"\n[[devices]]\nname = "fog"\nformat = "dsp1760"\nurl = "loop://"\n'
        'mounting = { xyz = [0.1, 0.0, 0.2], rpy_deg = [0.0, 0.0, 90.0] }\n'
        "[sonar]\ntilt_deg = 30.0\nspread_deg = 14.0\nwindow_start = 1.0\nwindow_length = 10.0\n"
    )
    path = tmp_path / "m.mcap"
    with MissionLogWriter(path) as log:
        log.add_vehicle_config(config)
        truth = {"scene": "seed = 7", "objects": [{"class": "sphere", "position": [30.0, 12.0]}]}
        log.add_ground_truth(truth, meshes={"sphere.stl": b"solid sphere\nendsolid\n"})
        log("fog", "dsp1760", T0, gyro_frame(0))
    with MissionLogReader(path) as r:
        meta = r.metadata(decode_json=True)
        assert meta["software"]["name"] == "auvlink"
        assert meta["vehicle_config"]["config"]["devices"][0]["mounting"]["rpy_deg"] == [0.0, 0.0, 90.0]
        assert meta["vehicle_config"]["config"]["sonar"]["tilt_deg"] == 30.0
        assert "name = \"auv7\"" in meta["vehicle_config"]["toml"]
        assert meta["ground_truth"]["objects"][0]["class"] == "sphere"
        (att,) = r.attachments()
        assert (att.name, att.media_type) == ("sphere.stl", "model/stl")
        assert r.read_attachment("sphere.stl") == b"solid sphere\nendsolid\n"
        with pytest.raises(LogError):
            r.read_attachment("nope")


def test_json_channels_follow_their_schemas(tmp_path: Path) -> None:
    path = tmp_path / "m.mcap"
    pose = pose_message(T0, (1.0, 2.0, 20.0), (0.0, 0.0, 0.0, 1.0))
    det = detection_message({"id": 0, "class": "sphere", "score": 0.9, "position_ned": [30, 12, 20],
                             "size": [1, 1, 1], "n_points": 120, "t_first": 1.0, "t_last": 9.0, "extra": 1})
    validate(pose, POSE_SCHEMA_NAME)
    validate(det, DETECTION_SCHEMA_NAME)
    with pytest.raises(LogError):
        validate({"id": 0}, DETECTION_SCHEMA_NAME)
    with MissionLogWriter(path) as log:
        log.add_json("nav/pose", POSE_SCHEMA_NAME, POSE_SCHEMA, T0, pose)
        log.add_json("detections", DETECTION_SCHEMA_NAME, DETECTION_SCHEMA, T0 + 1, det)
    with MissionLogReader(path) as r:
        msgs = list(r.messages())
        ch = r.channels["nav/pose"]
        assert (ch.message_encoding, ch.schema_encoding, ch.schema_name, ch.format) == (
            "json", "jsonschema", "foxglove.PoseInFrame", None)
    assert json.loads(msgs[0].data) == pose
    assert json.loads(msgs[1].data) == det
    with open(path, "rb") as f:  # the schema text is a valid JSON Schema in the file
        (schema,) = [s for s in make_reader(f).get_summary().schemas.values()  # type: ignore[union-attr]
                     if s.name == POSE_SCHEMA_NAME]
        assert json.loads(schema.data) == POSE_SCHEMA


def test_flush_interval_closes_idle_chunks(tmp_path: Path) -> None:
    """A frame written and then nothing: the background flusher still puts it on disk in time."""
    path = tmp_path / "m.mcap"
    with MissionLogWriter(path, flush_interval=0.1, chunk_size=1 << 20) as log:
        log("fog", "dsp1760", T0, gyro_frame(0))
        open_path = log.partial  # m.mcap.partial until closed (what a crash leaves), then renamed
        assert open_path.name == "m.mcap.partial" and not path.exists()
        size0 = open_path.stat().st_size
        deadline = time.monotonic() + 2.0
        while open_path.stat().st_size == size0 and time.monotonic() < deadline:
            time.sleep(0.01)
        with MissionLogReader(open_path) as r:  # readable while the writer is still open
            assert [m.data for m in r.messages()] == [gyro_frame(0)]
            assert not r.complete
    assert path.stat().st_size > size0 and not open_path.exists()


def test_writer_errors(tmp_path: Path) -> None:
    with pytest.raises(LogError):
        MissionLogWriter(tmp_path / "no" / "such" / "dir.mcap")
    with pytest.raises(LogError):
        MissionLogWriter(tmp_path / "x.mcap", compression="bz2")
    log = MissionLogWriter(tmp_path / "y.mcap")
    log("a", "dsp1760", T0, b"x")
    with pytest.raises(LogError):
        log("a", "pd0", T0, b"x")  # a device keeps its format
    with pytest.raises(LogError):
        log("a", "dsp1760", -1, b"x")  # MCAP times are u64
    log("a", "dsp1760", T0 + 1, b"y")  # the writer is still fine
    log.close()
    assert [m.data for m in read_messages(tmp_path / "y.mcap")] == [b"x", b"y"]
    log.close()
    with pytest.raises(LogError):
        log("a", "dsp1760", T0, b"x")
    with pytest.raises(LogError):
        MissionLogReader(tmp_path / "missing.mcap")
    (tmp_path / "text.mcap").write_text("hello")
    with pytest.raises(LogError):
        MissionLogReader(tmp_path / "text.mcap")


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.tuples(st.sampled_from(["a", "b", "c"]), st.integers(0, 10**12), st.binary(max_size=300)),
                max_size=60),
       st.integers(64, 2000))
def test_round_trip_property(tmp_path: Path, frames: list[tuple[str, int, bytes]], chunk: int) -> None:
    path = tmp_path / "p.mcap"
    with MissionLogWriter(path, chunk_size=chunk, flush_interval=0, fsync=False, software=False) as log:
        for device, t, raw in frames:
            log(device, "dsp1760", t, raw)
    got = [(m.channel, m.log_time_ns, m.data) for m in read_messages(path)]
    # stable: equal times keep the order they were written in
    assert got == sorted(frames, key=lambda f: f[1])


def test_reads_unchunked_mcap_from_other_writers(tmp_path: Path) -> None:
    """An MCAP file written without chunks (top-level messages) by another tool still reads."""
    from mcap.writer import Writer

    path = tmp_path / "foreign.mcap"
    with open(path, "wb") as f:
        w = Writer(f, use_chunking=False)
        w.start(profile="", library="other")
        sid = w.register_schema("kvh.dsp1760", "", b"")
        cid = w.register_channel("gyro", "kvh.dsp1760", sid, {"format": "dsp1760"})
        cid2 = w.register_channel("note", "text", 0)
        for i in range(5):
            w.add_message(cid, T0 + i * 10, gyro_frame(i), T0 + i * 10)
        w.add_message(cid2, T0 + 25, b"hello", T0 + 25)
        w.finish()
    with MissionLogReader(path) as log:
        got = [(m.channel, m.format, m.log_time_ns - T0) for m in log.messages()]
        assert log.complete and log.index.library == "other"
    assert got == [("gyro", "dsp1760", 0), ("gyro", "dsp1760", 10), ("gyro", "dsp1760", 20),
                   ("note", None, 25), ("gyro", "dsp1760", 30), ("gyro", "dsp1760", 40)]
