"""bench e2e's profile of the slowest stage (benchmarks/_stage_profile.py): the stage's own functions, no other's."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from auvlink.cli.bench import benchmarks_dir

sys.path.insert(0, str(benchmarks_dir()))

from _stage_profile import ENTRY_POINTS, profile_stage, run_child, slowest_stage

CHILD_TIMEOUT_S = 240.0  # under pytest-timeout's 300 s, so a stuck child fails the test with its log


def _profile(log: Path, stage: str, top: int, work: Path) -> dict:
    """The profiled replay in a child process, as ``bench e2e`` runs it (a profiler inside the pytest worker,
    under pytest-timeout's signal handler, is not what users run)."""
    prof = run_child(log, stage, work, top=top, timeout_s=CHILD_TIMEOUT_S)
    assert prof is not None, (work / "stage-profile.log").read_text()[-3000:]
    return prof


def test_slowest_stage_is_the_largest_profiled_timing() -> None:
    timings = {"start_up_s": 9.0, "total_s": 20.0, "replay_decode_s": 1.0, "clustering_s": 2.5,
               "classification_s": 0.4}
    assert slowest_stage(timings) == "clustering_s"
    assert slowest_stage({"total_s": 3.0}) is None
    with pytest.raises(ValueError, match="entry point"):
        profile_stage(Path("no.mcap"), "total_s")


@pytest.mark.slow
def test_profile_holds_the_stage_only(small_mission_log: Path, tmp_path: Path) -> None:
    prof = _profile(small_mission_log, "clustering_s", 40, tmp_path)
    names = [r["function"] for r in prof["top"]]
    assert any("(poll)" in n for n in names), names
    assert not any("(add_frames)" in n or "(label)" in n for n in names), names  # other stages stay out
    assert 0.0 < prof["profiled_s"] and prof["stage_s_in_profiled_run"] > 0.0
    assert all(r["cumtime_s"] >= 0.0 and r["ncalls"] >= 1 for r in prof["top"])
    assert set(ENTRY_POINTS) >= {"replay_decode_s", "clustering_s", "classification_s"}


@pytest.mark.slow
def test_decode_profile_follows_the_generator(small_mission_log: Path, tmp_path: Path) -> None:
    """Decoding is a generator: the profile is on for each item it yields, so the decoders show in it."""
    prof = _profile(small_mission_log, "replay_decode_s", 60, tmp_path)
    names = [r["function"] for r in prof["top"]]
    assert any("decoder.py" in n for n in names), names
    assert not any("(poll)" in n or "(add_frames)" in n for n in names), names
