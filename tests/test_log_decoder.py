"""Raw channels that say what they are (issue 17): each raw channel's schema names its wire format and
spec, and ``logs_format.decoder.DecoderFactory`` makes ``mcap``'s ``iter_decoded_messages`` yield
auvlink records for every raw channel, of new logs and of logs with the old empty schemas."""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from mcap.exceptions import DecoderNotFoundError
from mcap.reader import make_reader
from mcap.writer import Writer
from scenes import obj, scene_toml

from auvlink import formats
from auvlink.sim.mission import simulate_to_log
from auvlink.sim.scene import loads_scene
from logs_format import DecoderFactory
from logs_format.specs import SPECS, parse_descriptor

# one 10 m line over a pipe, with a GNSS receiver at the surface before and after
SCENE = scene_toml(seed=3, site={"latitude": 36.0412, "longitude": 129.3915},
                   gnss={"rate_hz": 1.0, "sigma_m": 0.3, "wait_before_s": 3.0, "wait_after_s": 3.0,
                         "lever_arm": [0.0, 0.0, -0.5]},
                   objects=[obj("pipe", 8.0, 0.0, 0.0)], survey={"line_length": 10.0}, sonar={"fps": 5.0})


@pytest.fixture(scope="module")
def sim_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("decoder") / "mission.mcap"
    simulate_to_log(loads_scene(SCENE), path, progress=False)
    return path


def decode_all(path: Path) -> tuple[dict[str, list[object]], dict[str, tuple[str, str, bytes, str]], Counter[str]]:
    records: dict[str, list[object]] = {}
    schemas: dict[str, tuple[str, str, bytes, str]] = {}
    raw: Counter[str] = Counter()
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for schema, channel, _message, rec in reader.iter_decoded_messages():
            records.setdefault(channel.topic, []).append(rec)
            assert schema is not None
            schemas[channel.topic] = (schema.name, schema.encoding, schema.data, channel.message_encoding)
    with open(path, "rb") as f:
        for _s, channel, _m in make_reader(f).iter_messages():
            raw[channel.topic] += 1
    return records, schemas, raw


@pytest.mark.slow
def test_every_raw_channel_of_a_simulated_log_decodes_through_the_factory(sim_log: Path) -> None:
    records, schemas, raw = decode_all(sim_log)
    wire = {t: s for t, s in schemas.items() if s[3] != "json"}
    assert {"dvl", "gyro", "pressure", "sonar", "gnss"} <= set(wire), set(wire)
    for topic, (name, encoding, data, msg_encoding) in wire.items():
        desc = parse_descriptor(data)
        assert desc is not None, topic
        fmt = formats.get(desc["format"])
        assert (name, encoding, desc["encoding"]) == (f"auvlink.{msg_encoding}", msg_encoding, fmt.encoding)
        assert desc["spec"]["url"].startswith("https://") and desc["spec"]["title"] == SPECS[fmt.name].title
        assert len(records[topic]) == raw[topic] > 0  # every message, decoded
        rec = records[topic][0]
        assert f"{type(rec).__module__}.{type(rec).__qualname__}" in desc["record"].split(" | "), topic
    with open(sim_log, "rb") as f:  # the same record as the codec gives the raw frame
        (_, _, message), = [m for m in make_reader(f).iter_messages(topics=["dvl"])][:1]
    dvl = formats.get("pd0")
    assert dvl.to_json is not None and records["dvl"][0] is not None
    assert json.dumps(dvl.to_json(records["dvl"][0]), default=str) == json.dumps(
        dvl.to_json(dvl.decode(message.data)), default=str)
    sonar = records["sonar"][0]
    assert np.asarray(sonar.image).shape == (512, 96)  # type: ignore[attr-defined]


def test_a_frame_that_does_not_decode_raises_or_is_kept(tmp_path: Path) -> None:
    from auvlink.errors import DecodeError
    from logs_format import MissionLogWriter
    from logs_format.decoder import UndecodedFrame

    path = tmp_path / "garbage.mcap"
    good = b"*00012991.11891\r\n"
    with MissionLogWriter(path, flush_interval=0) as log:
        log("pressure", "paro", 1_000, good)
        log("pressure", "paro", 2_000, b"*0001garbage\r\n")
    with open(path, "rb") as f, pytest.raises(DecodeError):
        list(make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages())
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory(errors="keep")])
        recs = [r for *_, r in reader.iter_decoded_messages()]
    assert recs[0] == formats.get("paro").decode(good)
    assert isinstance(recs[1], UndecodedFrame) and recs[1].format == "paro" and recs[1].data.endswith(b"garbage\r\n")


@pytest.mark.slow
def test_without_the_factory_mcap_cannot_decode_them(sim_log: Path) -> None:
    with open(sim_log, "rb") as f, pytest.raises(DecoderNotFoundError):
        for _ in make_reader(f).iter_decoded_messages(topics=["dvl"]):
            pass


@pytest.mark.slow
def test_old_logs_with_empty_schemas_decode_by_channel_encoding(sim_log: Path, tmp_path: Path) -> None:
    """A log of an earlier version: raw channels with schema name = encoding, no schema encoding, no data."""
    old = tmp_path / "old.mcap"
    with open(sim_log, "rb") as src, open(old, "wb") as dst:
        w = Writer(dst)
        w.start(profile="auvlink", library="auvlink/0.0 (old)")
        ids: dict[int, int] = {}
        for schema, channel, message in make_reader(src).iter_messages():
            if channel.id not in ids:
                if channel.message_encoding == "json":
                    sid = w.register_schema(schema.name, schema.encoding, schema.data) if schema else 0
                else:
                    sid = w.register_schema(channel.message_encoding, "", b"")
                ids[channel.id] = w.register_channel(channel.topic, channel.message_encoding, sid, channel.metadata)
            w.add_message(ids[channel.id], message.log_time, message.data, message.publish_time, message.sequence)
        w.finish()
    new_records, _, _ = decode_all(sim_log)
    old_records, schemas, raw = decode_all(old)
    for topic, (name, encoding, data, msg_encoding) in schemas.items():
        if msg_encoding == "json":
            continue
        assert (name, encoding, data) == (msg_encoding, "", b"")
        assert len(old_records[topic]) == raw[topic]
        assert [type(r) for r in old_records[topic]] == [type(r) for r in new_records[topic]]
