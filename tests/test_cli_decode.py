"""``auvlink decode`` end to end on real captures: JSON lines, summaries, damaged and empty files."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from auvlink.cli import main


def test_pd0_jsonl_fields(shared_data: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["decode", str(shared_data / "rdi" / "winriver01.PD0"), "--format", "pd0", "--jsonl"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 262
    first = json.loads(lines[0])
    for key in ("ensemble_number", "time", "coordinate_system", "heading_deg", "pitch_deg", "roll_deg",
                "temperature_c", "bt_velocity_mps", "bt_range_m", "velocity_mps"):
        assert key in first, key
    assert first["coordinate_system"] == "ship"
    assert [round(v * 1000) for v in first["bt_velocity_mps"]] == [186, -994, -50, -4]
    assert [round(v * 100) for v in first["bt_range_m"]] == [4171, 3926, 4130, 4090]
    assert first["time"].endswith("Z")


def test_bad_values_are_null(shared_data: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["decode", str(shared_data / "rdi" / "RDI_withBT.000"), "--format", "pd0", "--jsonl"]) == 0
    rows = [json.loads(x) for x in capsys.readouterr().out.splitlines()]
    assert len(rows) == 1721
    assert rows[0]["bt_velocity_mps"].count(None) == 4  # no bottom lock at the start
    assert rows[507]["bt_velocity_mps"] == pytest.approx([0.052, 0.062, 0.091, -0.003])


def test_corrupted_file_reports_and_keeps_good(shared_data: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = shared_data / "rdi" / "LB180210_3_corrupted.PD0"
    assert main(["decode", str(path), "--format", "pd0", "--json"]) == 0
    captured = capsys.readouterr()
    summary = json.loads(captured.out)
    assert summary["records"] == 2 and summary["framer"]["bad_checksums"] == 1
    assert "bad checksum" in captured.err


def test_truncated_tail_reported(shared_data: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["decode", str(shared_data / "rdi" / "RDI_test01.000"), "--format", "pd0"]) == 0
    captured = capsys.readouterr()
    assert "records     22" in captured.out
    assert "truncated" in captured.err


def test_nothing_decodable_exits_nonzero_one_line(tmp_path: Path) -> None:
    junk = tmp_path / "junk.bin"
    junk.write_bytes(bytes(range(256)) * 10)
    proc = subprocess.run([sys.executable, "-m", "auvlink", "decode", str(junk), "--format", "pd0"],
                          capture_output=True, text=True)
    assert proc.returncode != 0
    assert "Traceback" not in proc.stderr
    assert "no pd0 record could be decoded" in proc.stderr


def test_missing_file_one_line(tmp_path: Path) -> None:
    proc = subprocess.run([sys.executable, "-m", "auvlink", "decode", str(tmp_path / "nope"), "-f", "aris"],
                          capture_output=True, text=True)
    assert proc.returncode == 1 and "Traceback" not in proc.stderr and "no such file" in proc.stderr


def test_aris_summary(shared_data: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["decode", str(shared_data / "aris" / "sample.aris"), "--format", "aris", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["records"] == 6 and summary["t_first"].startswith("2013-06-14")


def test_losses_reported_by_kind(shared_data: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Garbage, a frame with a bad checksum and a truncated tail are three separate figures (the tail is
    not every dropped byte)."""
    from auvlink import formats

    good = formats.get("pd0").framer().feed((shared_data / "rdi" / "RDI_withBT.000").read_bytes())[:5]
    damaged = bytearray(good[2])
    damaged[len(damaged) // 2] ^= 0xFF
    garbage = bytes(range(1, 101))  # no 0x7f: cannot start an ensemble
    path = tmp_path / "crafted.pd0"
    path.write_bytes(good[0] + garbage + good[1] + bytes(damaged) + good[3] + good[4][:300])
    assert main(["decode", str(path), "--format", "pd0", "--json"]) == 0
    captured = capsys.readouterr()
    summary = json.loads(captured.out)
    assert summary["records"] == 3
    assert summary["losses"] == {"skipped_bytes": len(garbage) + len(damaged), "bad_checksums": 1,
                                 "truncated_frames": 1, "truncated_tail_bytes": 300}
    assert "1 frame(s) with a bad checksum" in captured.err
    assert f"{len(garbage) + len(damaged)} bytes outside any whole frame" in captured.err
    assert "a truncated frame of 300 bytes at the end" in captured.err
    # a real capture: 9768 bytes of junk before the end, then a 512-byte partial ensemble
    assert main(["decode", str(shared_data / "rdi" / "RDI_7f79.000"), "--format", "pd0"]) == 0
    captured = capsys.readouterr()
    assert "9768 bytes skipped outside frames, truncated tail 512 bytes" in captured.out
    assert "a truncated frame of 512 bytes at the end" in captured.err


def test_oculus_json_gives_the_capture_facts(shared_data: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """`decode --json` carries the first and last records' fields: the facts of the Oculus capture's README."""
    assert main(["decode", str(shared_data / "oculus" / "one_ping_8bit.raw"), "--format", "oculus", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    ping = summary["first_record"]
    assert summary["records"] == 1 and summary["last_record"] == ping
    assert (ping["ping_id"], ping["n_beams"], ping["n_ranges"]) == (415323, 256, 703)
    assert (ping["bearing_min_deg"], ping["bearing_max_deg"]) == (-30.0, 30.0)
    assert ping["frequency_hz"] == pytest.approx(2098880.6, abs=0.05)
    assert ping["range_resolution_m"] == 0.0028421889710794315
    assert ping["image_mean"] == pytest.approx(55.857, abs=5e-4)


def test_json_first_and_last_records_differ_on_a_long_file(
    shared_data: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["decode", str(shared_data / "rdi" / "RDI_withBT.000"), "--format", "pd0", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["records"] == 1721
    assert summary["first_record"] != summary["last_record"]
