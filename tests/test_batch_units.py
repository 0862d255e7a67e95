"""``auvlink batch``'s parts without a cluster: finding the logs, naming the missions, one mission at a
time per worker process, the version check, the output folder check."""

from __future__ import annotations

import threading
import time
from pathlib import Path
from typing import Any

import pytest

from auvlink.errors import AuvlinkError, OutputError
from auvlink.pipeline import batch_mission
from auvlink.pipeline.batch import check_batch_dir, discover_logs, mission_names, settings_of
from auvlink.pipeline.batch_mission import MissionTask, run_mission
from logs_format.records import MAGIC


def _touch(p: Path) -> Path:
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_bytes(b"x")
    return p


def test_discover_logs(tmp_path: Path) -> None:
    a = _touch(tmp_path / "2025" / "a.mcap")
    b = _touch(tmp_path / "2025" / "deep" / "b.mcap")
    _touch(tmp_path / "2025" / ".hidden" / "c.mcap")
    _touch(tmp_path / "2025" / "notes.txt")
    _touch(tmp_path / "2025" / ".d.mcap")
    single = _touch(tmp_path / "one.mcap")
    assert discover_logs([single, tmp_path / "2025", a]) == [single, a, b]  # each once, in the order given
    with pytest.raises(AuvlinkError, match="no such log or folder"):
        discover_logs([tmp_path / "nope"])
    (tmp_path / "empty").mkdir()
    with pytest.raises(AuvlinkError, match=r"no \.mcap logs"):
        discover_logs([tmp_path / "empty"])


def test_mission_names_are_unique_and_stable() -> None:
    logs = [Path("/d/2025/mission.mcap"), Path("/d/2026/mission.mcap"), Path("/d/x/other.mcap"),
            Path("/e/2025/mission.mcap")]
    assert mission_names(logs) == ["2025-mission", "2026-mission", "other", "2025-mission-2"]
    assert mission_names(logs[:3]) == mission_names(logs)[:3]


def _task(tmp_path: Path, name: str, **kw: Any) -> MissionTask:
    log = _touch(tmp_path / f"{name}.mcap")
    log.write_bytes(MAGIC)  # a log starts with it: the batch checks it before the checksum
    settings = {**settings_of(None, False, False, None), **kw}
    return MissionTask(name, str(log), str(tmp_path / "out" / name), settings, classify=False, report=False)


def test_one_mission_at_a_time_per_worker_process(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    running, peak = [0], [0]
    guard = threading.Lock()

    def fake(task: MissionTask, digest: str) -> dict[str, Any]:
        with guard:
            running[0] += 1
            peak[0] = max(peak[0], running[0])
        time.sleep(0.2)
        with guard:
            running[0] -= 1
        return {"detections": 0, "duration_s": 1.0}

    monkeypatch.setattr(batch_mission, "process_mission", fake)
    tasks = [_task(tmp_path, f"m{i}") for i in range(3)]
    results: list[Any] = []
    threads = [threading.Thread(target=lambda t=t: results.append(run_mission(t))) for t in tasks]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert [r.status for r in results] == ["done"] * 3 and peak[0] == 1


def test_worker_of_another_version_fails_the_mission(tmp_path: Path) -> None:
    out = run_mission(_task(tmp_path, "m", auvlink="0.0.1"))
    assert out.status == "failed" and "the client 0.0.1" in out.error and "same version" in out.error


def test_batch_dir_check(tmp_path: Path) -> None:
    check_batch_dir(tmp_path / "new", force=False)
    _touch(tmp_path / "used" / "a.txt")
    with pytest.raises(OutputError, match="not an auvlink batch folder"):
        check_batch_dir(tmp_path / "used", force=False)
    check_batch_dir(tmp_path / "used", force=True)
    (tmp_path / "used" / "batch.json").write_text('{"format": "auvlink-batch/1"}')
    check_batch_dir(tmp_path / "used", force=False)  # an earlier batch's folder: resumed
    with pytest.raises(OutputError, match="not a folder"):
        check_batch_dir(tmp_path / "used" / "a.txt", force=True)
