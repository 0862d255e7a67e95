"""The vectorized PD0 reader agrees with the per-frame codec on every real capture."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from auvlink.codecs import pd0
from auvlink.codecs.pd0_bulk import decode_file_bulk, find_ensembles
from auvlink.framing.pd0 import Pd0Framer

FILES = [
    "RDI_withBT.000", "RDI_test01.000", "winriver01.PD0", "winriver02.PD0", "RDI_7f79.000",
    "adcp_auv_51.pd0", "adcp_auv_3.pd0", "ND072023.PD0", "LB180210_3_corrupted.PD0",
]


@pytest.mark.parametrize("name", FILES)
def test_bulk_matches_codec(shared_data: Path, name: str) -> None:
    data = (shared_data / "rdi" / name).read_bytes()
    framer = Pd0Framer()
    records = [pd0.decode(f) for f in framer.feed(data) + framer.flush()]
    batch = decode_file_bulk(data)
    assert len(batch) == len(records) > 0
    np.testing.assert_array_equal(batch.ensemble_number, [r.ensemble_number for r in records])
    np.testing.assert_allclose(batch.heading, [r.heading_rad for r in records], atol=1e-12)
    np.testing.assert_allclose(batch.pitch, [r.pitch_rad for r in records], atol=1e-12)
    np.testing.assert_allclose(batch.roll, [r.roll_rad for r in records], atol=1e-12)
    np.testing.assert_allclose(batch.temperature_c, [r.temperature_c for r in records], atol=1e-9)
    assert list(batch.coordinate_system) == [r.coordinate_system for r in records]
    bt_v = np.array([r.bt_velocity_mps if r.bottom_track is not None else [np.nan] * 4 for r in records])
    bt_r = np.array([r.bt_range_m if r.bottom_track is not None else [np.nan] * 4 for r in records])
    np.testing.assert_array_equal(np.isnan(batch.bt_velocity), np.isnan(bt_v))
    np.testing.assert_allclose(batch.bt_velocity, bt_v, atol=1e-12)
    np.testing.assert_allclose(batch.bt_range, bt_r, atol=1e-12)


def test_bulk_golden_with_bt(shared_data: Path) -> None:
    batch = decode_file_bulk((shared_data / "rdi" / "RDI_withBT.000").read_bytes())
    assert len(batch) == 1721
    all_valid = np.isfinite(batch.bt_velocity).all(axis=1)
    assert int(all_valid.sum()) == 898
    first = int(np.argmax(all_valid))
    assert first == 507
    np.testing.assert_allclose(batch.bt_velocity[first] * 1000, [52, 62, 91, -3])
    np.testing.assert_allclose(batch.bt_range[first] * 100, [686, 1039, 753, 905])


def test_bulk_finds_nothing_in_garbage() -> None:
    rng = np.random.default_rng(3)
    junk = rng.integers(0, 256, 50_000, dtype=np.uint8).tobytes() + b"\x7f\x7f\xff\xff"
    assert find_ensembles(junk) == []
    assert len(decode_file_bulk(junk)) == 0
    assert len(decode_file_bulk(b"")) == 0
