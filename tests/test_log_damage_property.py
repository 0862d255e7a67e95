"""Property: damage a small mission log at random (byte flips, cuts, zeroed ranges, inserted garbage);
no exception escapes the reader, ``log info`` or replay, and every chunk whose bytes are intact in the
damaged file is read in full (each of its messages comes out, on its channel)."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from auvlink.codecs import dsp1760
from logs_format import MissionLogReader, MissionLogWriter, log_info, replay_samples
from logs_format.chunks import ChunkOpener

pytestmark = pytest.mark.slow

T0 = 1_700_000_000_000_000_000
Msg = tuple[str, int, bytes]


def gyro(i: int) -> bytes:
    return dsp1760.encode(dsp1760.build((1e-5 * i, 2e-5, 0.0), (0.0, 0.0, -9.8), sequence=i))


class Original:
    """A small healthy log (~8 chunks, two channels, metadata) and, per chunk, its bytes and messages."""

    def __init__(self, path: Path, compression: str) -> None:
        with MissionLogWriter(path, chunk_size=600, flush_interval=0, fsync=False, compression=compression) as log:
            log.add_metadata("note", {"k": "v"})
            for i in range(40):
                log("fog", "dsp1760", T0 + i * 20_000_000, gyro(i))
                if i % 3 == 0:
                    log("ahrs", "dsp1760", T0 + i * 20_000_000 + 5, gyro(1000 + i))
        self.data = path.read_bytes()
        self.chunks: list[tuple[bytes, list[Msg]]] = []
        with MissionLogReader(path) as log, open(path, "rb") as f:
            topics = {ch.id: ch.topic for ch in log.discover_channels().values()}
            opener = ChunkOpener(f)
            for ref in log.chunks:
                _, _, msgs = opener.open(ref)
                record = self.data[ref.offset : ref.data_offset + ref.data_length]
                self.chunks.append((record, [(topics[cid], t, bytes(d)) for t, _, _, cid, d in msgs]))
            self.messages = Counter((m.channel, m.log_time_ns, m.data) for m in log.messages())
        assert len(self.chunks) >= 6 and sum(len(m) for _, m in self.chunks) == sum(self.messages.values())


@pytest.fixture(scope="module")
def originals(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Original]:
    folder = tmp_path_factory.mktemp("prop")
    return {c: Original(folder / f"{c}.mcap", c) for c in ("zstd", "lz4", "none")}


def damage(data: bytes, ops: list[tuple[str, float, int, bytes]]) -> bytes:
    """Apply (kind, where as a fraction of the length, size, garbage) edits in order."""
    out = bytearray(data)
    for kind, where, size, garbage in ops:
        pos = min(int(where * len(out)), max(len(out) - 1, 0))
        if kind == "flip" and out:
            out[pos] ^= 1 << (size % 8)
        elif kind == "cut":
            del out[max(pos, 1):]
        elif kind == "zero":
            out[pos : pos + size] = bytes(len(out[pos : pos + size]))
        elif kind == "insert":
            out[pos:pos] = garbage
    return bytes(out)


edits = st.lists(
    st.tuples(st.sampled_from(["flip", "flip", "cut", "zero", "insert"]), st.floats(0.0, 1.0),
              st.integers(1, 300), st.binary(min_size=1, max_size=64)),
    min_size=1, max_size=4)


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(compression=st.sampled_from(["zstd", "lz4", "none"]), ops=edits)
def test_random_damage_loses_only_damaged_chunks(originals: dict[str, Original], tmp_path: Path,
                                                 compression: str, ops: list[tuple[str, float, int, bytes]]) -> None:
    orig = originals[compression]
    bad = damage(orig.data, ops)
    path = tmp_path / "damaged.mcap"
    path.write_bytes(bad)
    if not bad.startswith(b"\x89MCAP0\r\n"):
        return  # not an MCAP file any more: refused with a LogError, tested elsewhere
    with MissionLogReader(path) as log:
        got = Counter((m.channel, m.log_time_ns, m.data) for m in log.messages())
        loss = log.loss
        assert loss.describe() and loss.to_json()["state"]
    for record, msgs in orig.chunks:
        if record in bad:
            for m in msgs:
                assert got[m] >= 1, (ops, m[:2])
    if compression != "none":  # CRC-checked chunks: nothing comes out that was not written, and only once
        assert not got - orig.messages, ops
    if bad != orig.data and got != orig.messages:
        assert loss.lossy or not loss.complete, ops
    info = log_info(path)
    assert info["message_count"] == sum(got.values())
    assert sum(1 for _ in replay_samples(path)) <= sum(got.values())
