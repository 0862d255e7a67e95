"""The engine's parts: its input queue releases events in time order however the watermarks cut the stream, and
its detection store keeps one detection per id (a later pass replaces it in place)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from auvlink import formats
from auvlink.codecs import paro
from auvlink.geodesy import Datum
from auvlink.pipeline.detection_store import DetectionStore
from auvlink.pipeline.event_queue import EventQueue
from auvlink.pipeline.georef import Georef
from auvlink.pipeline.results import Detection
from auvlink.records import Sample

WIRE = formats.get("paro")


def depth_sample(t_ns: int, pressure_pa: float) -> Sample:
    """A pressure reading received at ``t_ns`` (its wire bytes decoded, as a driver hands it over)."""
    return Sample("depth", "paro", t_ns, b"", WIRE.decode(WIRE.encode(paro.build_reading(pressure_pa))))


@settings(max_examples=100, deadline=None)
@given(times=st.lists(st.integers(1_000, 1_050), min_size=1, max_size=30),
       cuts=st.lists(st.integers(990, 1_060), max_size=5))
def test_the_events_come_out_in_time_then_arrival_order_whatever_the_watermarks(times: list[int],
                                                                                cuts: list[int]) -> None:
    queue = EventQueue()
    for k, t in enumerate(times):
        queue.put(depth_sample(t, 1.0e5 + 1.0e3 * k))  # the pressure tells the arrival k
    released = []
    for w in sorted(cuts):
        part = queue.release(w)
        assert all(e.t_ns < w for e in part)
        released += part
    released += queue.release(None)
    assert not queue
    assert [(e.t_ns, round((e.payload - 1.0e5) / 1.0e3)) for e in released] == sorted(
        (t, k) for k, t in enumerate(times))
    assert queue.t0_ns == times[0] and queue.seconds(times[0] + 2_000_000_000) == 2.0


def detection(det_id: int, north: float) -> Detection:
    return Detection(id=det_id, class_name="box", score=0.9, position_ned=(north, 0.0, 10.0), size=(1.0, 1.0, 0.5),
                     n_points=5, t_first=0.0, t_last=1.0, points=np.zeros((0, 3)))


def test_a_later_pass_replaces_its_detection_in_place() -> None:
    store = DetectionStore(Georef(Datum.of_site(None), (0.0, 0.0, 0.0), False))
    zero = np.zeros(3)
    assert store.put(detection(4, 1.0), zero) and store.put(detection(2, 5.0), zero)
    assert not store.put(detection(4, 1.5), zero)  # object 4 seen again: the update, same place
    assert [(d.id, d.position_ned[0]) for d in store.detections] == [(4, 1.5), (2, 5.0)]
    assert store.reported == {4: 0, 2: 1}
    store.finalize(0.0)
    assert [d.id for d in store.detections] == [4, 2]
