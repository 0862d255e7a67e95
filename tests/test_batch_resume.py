"""A batch resumes: a second run skips every mission done with the same log, model and settings; a corrupt
log among them is reported (one line, exit status 1) while the others complete; a mission folder from
other settings, or an output folder that is not a batch's, is not overwritten without ``--force``."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest
from batch_helpers import site_logs

from auvlink.cli import main
from auvlink.file_digest import HASH_BLOCK, sha256_file

pytestmark = pytest.mark.timeout(240)


def _run(out: Path) -> dict[str, dict[str, object]]:
    return {m["mission"]: m for m in json.loads((out / "batch.json").read_text())["missions"]}


@pytest.mark.slow
def test_resume_skips_done_missions_and_reports_a_corrupt_log(
        tmp_path: Path, tmp_path_factory: pytest.TempPathFactory, capsys: pytest.CaptureFixture[str]) -> None:
    good = site_logs(tmp_path_factory)[::2]
    logs = tmp_path / "logs"
    logs.mkdir()
    for p in good:
        os.symlink(p, logs / p.name)
    bad = logs / "corrupt.mcap"
    bad.write_bytes(b"\x89MCAP0\r\n" + os.urandom(200_000))  # the magic, then garbage
    out = tmp_path / "site"
    capsys.readouterr()
    assert main(["batch", str(logs), "--out", str(out), "--workers", "2", "--quiet"]) == 1
    cap = capsys.readouterr()
    first = _run(out)
    assert {k: v["status"] for k, v in first.items()} == {"corrupt": "failed", good[0].stem: "done",
                                                          good[1].stem: "done"}
    assert first["corrupt"]["error"] and "\n" not in str(first["corrupt"]["error"])
    errors = [line for line in cap.err.splitlines() if line.startswith("auvlink: error:")]
    assert len(errors) == 1 and str(bad) in errors[0]
    assert "1 failed" in cap.out and not (out / "corrupt").exists()
    stamps = {p.stem: (out / p.stem / "detections.jsonl").stat().st_mtime_ns for p in good}
    gj = json.loads((out / "catalogue.geojson").read_text())
    assert [m["name"] for m in gj["missions"]] == [p.stem for p in good]

    assert main(["batch", str(logs), "--out", str(out), "--workers", "2", "--quiet"]) == 1
    second = _run(out)
    assert {k: v["status"] for k, v in second.items()} == {"corrupt": "failed", good[0].stem: "skipped",
                                                           good[1].stem: "skipped"}
    for p in good:  # not rewritten, and the catalogue still holds both missions
        assert (out / p.stem / "detections.jsonl").stat().st_mtime_ns == stamps[p.stem]
        assert second[p.stem]["detections"] == first[p.stem]["detections"]
    assert json.loads((out / "catalogue.geojson").read_text())["features"] == gj["features"]


@pytest.mark.slow
def test_other_settings_need_force(tmp_path: Path, tmp_path_factory: pytest.TempPathFactory,
                                   capsys: pytest.CaptureFixture[str]) -> None:
    log = site_logs(tmp_path_factory)[0]
    out = tmp_path / "site"
    # a mission folder from another model: kept without --force
    (out / log.stem).mkdir(parents=True)
    rec = {"format": "auvlink-batch-mission/1", "mission": log.stem, "log_sha256": sha256_file(log),
           "settings": {"model_sha256": "0" * 64}}
    (out / log.stem / "batch.json").write_text(json.dumps(rec))
    (out / "batch.json").write_text(json.dumps({"format": "auvlink-batch/1"}))
    assert main(["batch", str(log), "--out", str(out), "--workers", "1", "--quiet", "--no-report"]) == 1
    err = capsys.readouterr().err
    assert "from another log, model or settings; give --force" in err
    assert json.loads((out / log.stem / "batch.json").read_text()) == rec
    # a folder that is not a batch's: refused before any work
    other = tmp_path / "photos"
    other.mkdir()
    (other / "keep.jpg").write_bytes(b"x")
    assert main(["batch", str(log), "--out", str(other)]) == 1
    assert "not an auvlink batch folder" in capsys.readouterr().err
    assert sorted(os.listdir(other)) == ["keep.jpg"]


def test_streaming_checksum(tmp_path: Path) -> None:
    import hashlib

    data = os.urandom(3 * HASH_BLOCK + 17)
    (tmp_path / "f").write_bytes(data)
    assert sha256_file(tmp_path / "f") == hashlib.sha256(data).hexdigest()
    shutil.copy(tmp_path / "f", tmp_path / "g")
    with open(tmp_path / "g", "r+b") as f:  # one bit in the last block
        f.seek(len(data) - 1)
        f.write(bytes([data[-1] ^ 1]))
    assert sha256_file(tmp_path / "g") != sha256_file(tmp_path / "f")
