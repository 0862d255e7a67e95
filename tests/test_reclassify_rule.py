"""When a reported object's later pass is classified: at once when its evidence changed enough (points x1.25, an
extent axis by more than 20 %), else on its final cloud at the end (ObjectLabeller.take_deferred)."""

from __future__ import annotations

import pytest
from labelled_objects import SEABED_DEPTH_M, box_object, loaded_labeller

from auvlink.pipeline.object_labels import RECLASSIFY_EXTENT, RECLASSIFY_GROWTH, ObjectLabeller
from recon.cluster import DetectedObject


def _object(oid: int, n: int, size: tuple[float, float, float], seed: int = 0) -> DetectedObject:
    """``n`` points uniform in a box of ``size`` m resting on the seabed (NED)."""
    return box_object(oid, n, (0.0, 0.0, SEABED_DEPTH_M - size[2]), (size[0], size[1], SEABED_DEPTH_M), seed)


@pytest.fixture(scope="module")
def labeller() -> ObjectLabeller:
    return loaded_labeller()


def test_small_change_keeps_the_class_until_the_end(labeller: ObjectLabeller) -> None:
    first = _object(1, 400, (1.0, 2.0, 0.5))
    (label,) = labeller.label([first], reported=set())
    before = labeller.forward_clouds
    later = _object(1, int(400 * (RECLASSIFY_GROWTH - 0.1)), (1.0, 2.0, 0.5), seed=1)  # a few more points
    assert labeller.label([later], reported={1}) == [label]
    assert labeller.forward_clouds == before  # not run through the network
    deferred = labeller.take_deferred()
    assert [o.id for o in deferred] == [1] and deferred[0] is later
    assert labeller.take_deferred() == []
    final = labeller.label(deferred, reported={1}, final=True)
    assert labeller.forward_clouds == before + 1  # the final cloud is classified
    assert final[0][0] != "clutter"


@pytest.mark.parametrize("n, size", [(int(400 * RECLASSIFY_GROWTH) + 1, (1.0, 2.0, 0.5)),  # grew enough
                                     (400, (1.0, 2.0 * (1.0 + RECLASSIFY_EXTENT + 0.1), 0.5))])  # longer
def test_enough_change_is_classified_at_once(labeller: ObjectLabeller, n: int, size: tuple[float, float, float]
                                             ) -> None:
    labeller.label([_object(2, 400, (1.0, 2.0, 0.5))], reported=set())
    before = labeller.forward_clouds
    labeller.label([_object(2, n, size, seed=3)], reported={2})
    assert labeller.forward_clouds == before + 1
    assert 2 not in [o.id for o in labeller.take_deferred()]


def test_unreported_objects_are_always_classified(labeller: ObjectLabeller) -> None:
    labeller.label([_object(3, 400, (1.0, 2.0, 0.5))], reported=set())
    before = labeller.forward_clouds
    labeller.label([_object(3, 410, (1.0, 2.0, 0.5), seed=5)], reported=set())  # called clutter or not: afresh
    assert labeller.forward_clouds == before + 1
