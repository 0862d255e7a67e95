"""The byte decoder (framer + codec + counters) is pure: the same bytes give the same samples and the same
counters however they are cut into chunks, each sample stamped with the time of the chunk that completed
its frame; the live driver and replay both run it (the driver adds the transport and the listeners)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from auvlink import formats
from auvlink.decoder import Decoder
from auvlink.driver import Driver
from auvlink.records import Sample

#: formats whose framer may hold a whole frame until the next bytes rule out a longer one (Keller frames
#: carry no length: a request can be the start of a response)
LOOKAHEAD = {"keller"}
GARBAGE = (b"", b"\x00", b"\x13\x37\x00", b"zz\r\n", b"\xff" * 5)


def _streams() -> dict[str, bytes]:
    """Per format: real or encoded frames with garbage between them, and one frame with a flipped bit."""
    from auvlink.codecs import can_nav, didson, dsp1760, dsp3000, keller, paro, pd0_build
    from auvlink.codecs import pd0 as pd0_codec

    rng = np.random.default_rng(11)
    frames = {
        "dsp1760": [dsp1760.encode(dsp1760.build((1e-4 * i, 2e-5, -1e-4), (0.1, 0.0, -9.8), sequence=i))
                    for i in range(6)],
        "can": [can_nav.encode(can_nav.build(n)) for n in can_nav.message_names()[:6]],
        "paro": [paro.encode(paro.build_reading(101325.0 + 1e3 * i)) for i in range(6)],
        "dsp3000": [dsp3000.encode(dsp3000.build(0.01 * i - 0.5)) for i in range(6)],
        "keller": [keller.encode(r) for i in range(3) for r in
                   (keller.KellerReadRequest(1, 1), keller.build_pressure_response(1, 2.0e5 + 1e3 * i))],
        "pd0": [pd0_codec.encode(pd0_build.build(i, 1.7e9 + i, bt_velocity_mps=(0.5, 0.1, 0.0, 0.01),
                                                  bt_range_m=(5.0, 5.1, 5.2, 5.3), n_cells=4))
                for i in range(4)],
        "pd6": [b":BS,   +100,   -20,   +5,A\r\n", b":SA,  +1.50,  -0.75, 123.45\r\n"] * 3,
        "didson": [didson.encode(didson.build(rng.integers(0, 256, (64, 96), dtype=np.uint8), 1.0, 10.0,
                                              frame_index=i)) for i in range(3)],
    }
    out = {}
    for fmt, fr in frames.items():
        bad = bytearray(fr[1])
        bad[len(bad) // 2] ^= 0x04
        parts = [GARBAGE[i % len(GARBAGE)] + f for i, f in enumerate([fr[0], bytes(bad), *fr[2:]])]
        out[fmt] = b"".join(parts)
    return out


STREAMS = _streams()


def _record(fmt: str, s: Sample) -> object:
    to_json = formats.get(fmt).to_json
    return to_json(s.record) if to_json is not None else repr(s.record)


def _feed(fmt: str, stream: bytes, cuts: list[int]) -> tuple[list[Sample], Decoder, list[int]]:
    """Feed ``stream`` cut at ``cuts``, chunk k received at t = 1000 + 10 k ns; then flush."""
    dec = Decoder("dev", fmt)
    edges = [0, *sorted(set(cuts)), len(stream)]
    out: list[Sample] = []
    for k, (a, b) in enumerate(itertools.pairwise(edges)):
        out += dec.feed(stream[a:b], 1000 + 10 * k)
    out += dec.flush(999_999)
    return out, dec, edges


def _stamp(stream: bytes, samples: list[Sample], edges: list[int]) -> list[int]:
    """The time of the chunk holding each frame's last byte (frames found in order in the stream)."""
    stamps, pos = [], 0
    for s in samples:
        start = stream.index(s.raw, pos)
        pos = start + len(s.raw)
        chunk = next(k for k, b in enumerate(edges[1:]) if pos <= b)
        stamps.append(1000 + 10 * chunk)
    return stamps


@pytest.mark.parametrize("fmt", sorted(STREAMS))
def test_the_stream_decodes_its_good_frames_and_counts_the_bad_one(fmt: str) -> None:
    samples, dec, _ = _feed(fmt, STREAMS[fmt], [])
    assert len(samples) >= 2 and all(s.device == "dev" and s.format == fmt for s in samples)
    assert dec.stats.samples == len(samples)
    assert dec.stats.decode_errors + dec.framer.stats.bad_checksums + dec.framer.stats.dropped_bytes > 0


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(fmt=st.sampled_from(sorted(STREAMS)), data=st.data())
def test_any_chunking_gives_the_same_samples_and_counters(fmt: str, data: st.DataObject) -> None:
    stream = STREAMS[fmt]
    ref, ref_dec, _ = _feed(fmt, stream, [])
    cuts = data.draw(st.lists(st.integers(1, len(stream) - 1), max_size=12))
    if data.draw(st.booleans()):  # or byte by byte through a stretch of the stream
        a = data.draw(st.integers(0, len(stream) - 1))
        cuts += list(range(a, min(a + 300, len(stream))))
    got, dec, edges = _feed(fmt, stream, cuts)
    assert [s.raw for s in got] == [s.raw for s in ref]
    assert [_record(fmt, s) for s in got] == [_record(fmt, s) for s in ref]
    assert [s.t_sensor for s in got] == [s.t_sensor for s in ref]
    stamps, done = [s.t_host_ns for s in got], _stamp(stream, got, edges)
    assert stamps == sorted(stamps) and all(t >= d for t, d in zip(stamps, done, strict=True))
    if fmt not in LOOKAHEAD:
        assert stamps == done
    assert dec.describe() == ref_dec.describe()
    assert dec.stats.last_error == ref_dec.stats.last_error


def test_a_frame_split_across_a_reset_is_forgotten_and_the_next_is_kept() -> None:
    from auvlink.codecs import dsp1760

    a, b = (dsp1760.encode(dsp1760.build((0.0, 0.0, 0.01 * i), (0.0, 0.0, 9.8), sequence=i)) for i in range(2))
    dec = Decoder("gyro", "dsp1760")
    assert dec.feed(a[:20], 1) == []
    dec.reset()  # the port went: the first 20 bytes belong to no frame
    assert dec.feed(a[20:], 2) == []
    got = dec.feed(b, 3)
    assert [s.raw for s in got] == [b] and got[0].t_host_ns == 3 and dec.stats.samples == 1


def test_the_driver_reads_its_transport_into_the_same_decoder_and_reopening_starts_afresh() -> None:
    stream = STREAMS["paro"]
    with Driver("pressure", "paro", "loop://") as drv:
        assert isinstance(drv.decoder, Decoder) and drv.framer is drv.decoder.framer
        raw: list[bytes] = []
        drv.add_raw_listener(lambda dev, fmt, t, r: raw.append(r))
        drv.transport.write(stream)
        got: list[Sample] = []
        for _ in range(50):
            got += drv.read(0.05)
            if drv.transport.bytes_read >= len(stream):
                break
        drv.transport.write(b"*0001101")  # half a line, then the port is reopened
        drv.read(0.05)
        drv.close()
        drv.open()
        assert drv.framer.buffered == 0
    ref, ref_dec, _ = _feed("paro", stream, [])
    assert [s.raw for s in got] == [s.raw for s in ref]
    assert [_record("paro", s) for s in got] == [_record("paro", s) for s in ref]
    assert len(raw) == len(ref) + ref_dec.stats.decode_errors  # every cut frame reaches the raw listeners
    assert drv.stats.samples == len(ref)
