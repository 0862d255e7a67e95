"""Golden outputs: the small mission's ``detections.jsonl`` and ``summary.json`` (tests/golden/small_mission/)
compared exactly with a replay of today's code.

A change of behaviour anywhere in replay -> recon -> classify -> outputs shows here as a diff of the file.
When the change is meant, regenerate the files and commit them with it:

    AUVLINK_REGEN_GOLDEN=1 .venv/bin/pytest tests/test_golden_small_mission.py

``detections.jsonl`` is compared byte for byte. ``summary.json`` goes through :func:`normalized_summary` first,
which removes what changes from run to run of the same code: wall-clock timings (``timings``, the
``latency`` figures but their counts) and the log's path (``log``).
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import pytest
from small_mission import SmallMissionRun

pytestmark = pytest.mark.slow

GOLDEN = Path(__file__).resolve().parent / "golden" / "small_mission"
REGEN = os.environ.get("AUVLINK_REGEN_GOLDEN") == "1"
VOLATILE_KEYS = ("log", "timings")  # the log's temporary path; wall-clock seconds per stage
LATENCY_KEPT = ("count",)  # latency: how many times a stage ran is the code's; the milliseconds are the machine's


def normalized_summary(summary: dict[str, Any]) -> dict[str, Any]:
    """``summary`` without its volatile fields (see the module docstring); everything else as written."""
    kept = {k: v for k, v in summary.items() if k not in VOLATILE_KEYS}
    if "latency" in kept:
        kept["latency"] = {stage: {k: v for k, v in figures.items() if k in LATENCY_KEPT}
                           for stage, figures in kept["latency"].items()}
    return kept


def check_or_regen(name: str, got: str) -> None:
    """Compare ``got`` with golden/small_mission/``name`` (or write it when AUVLINK_REGEN_GOLDEN=1)."""
    path = GOLDEN / name
    if REGEN:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(got)
        return
    assert path.is_file(), f"{path} missing: run with AUVLINK_REGEN_GOLDEN=1 to write it"
    assert got == path.read_text(), f"{name} differs from {path} (AUVLINK_REGEN_GOLDEN=1 rewrites it if meant)"


def test_detections_jsonl_is_golden(small_mission_run: SmallMissionRun) -> None:
    check_or_regen("detections.jsonl", (small_mission_run.out / "detections.jsonl").read_text())


def test_summary_json_is_golden(small_mission_run: SmallMissionRun) -> None:
    summary = json.loads((small_mission_run.out / "summary.json").read_text())
    assert summary["log"] == str(small_mission_run.log) and summary["timings"]["total_s"] > 0.0
    check_or_regen("summary.json", json.dumps(normalized_summary(summary), indent=2, sort_keys=True) + "\n")


def test_normalizer_removes_only_the_volatile_fields() -> None:
    summary = {"log": "/tmp/x.mcap", "timings": {"total_s": 3.2}, "detections": 2,
               "latency": {"clustering": {"count": 6, "p50_ms": 80.5, "max_ms": 527.0}}}
    assert normalized_summary(summary) == {"detections": 2, "latency": {"clustering": {"count": 6}}}
