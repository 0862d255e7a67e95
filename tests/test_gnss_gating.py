"""GNSS fixes are gated before navigation uses them (issue 34): fix quality (6 estimated and 8 simulation are
counted, not used), plausible values (latitude 91.5, longitude 1e9, HDOP -5), no datum from a single fix, and a
closure error beyond what dead reckoning can drift refused (summary.json, report, one stderr line) with the
detections left where the dead-reckoned track puts them.

The whole-run cases replay a small simulated mission with GNSS whose NMEA sentences are rewritten into a copy of
the log: real GGA sentences with valid checksums (pynmea2), every other frame as the simulator wrote it.
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pynmea2
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from small_mission import SCENE

from auvlink.cli import main
from auvlink.codecs import nmea
from auvlink.pipeline.georef import DATUM_FIXES, Georef, GnssPayload
from auvlink.sim.mission import simulate_to_log
from auvlink.sim.scene import loads_scene
from logs_format import MissionLogReader, MissionLogWriter
from recon.nav_stream import CausalNavigator

GNSS_SCENE = SCENE + "[gnss]\nrate_hz = 2.0\nwait_before_s = 8.0\nwait_after_s = 6.0\nvertical_rate = 0.8\n"
DEG_10_KM = 10_000.0 / 111_000.0  # 10 km of latitude, deg (about 111 km per degree)
#: edits one GGA fix: (record, k, phase) -> the sentence to log instead (bytes with CR LF); phase: pre | post
Edit = Callable[[nmea.GgaFix, int, str], bytes]


def sentence(body: str) -> bytes:
    """``$body*hh`` CR LF with the checksum pynmea2 computes."""
    return f"${body}*{pynmea2.NMEASentence.checksum(body):02X}\r\n".encode("ascii")


def gga(fix: nmea.GgaFix, *, lat: str | None = None, lon: str | None = None, quality: int | None = None,
        hdop: str | None = None) -> bytes:
    """The fix as sent, some fields replaced (latitude / longitude as ``ddmm.mmmm,H``)."""
    f = list(fix.data)
    if lat is not None:
        f[1:3] = lat.split(",")
    if lon is not None:
        f[3:5] = lon.split(",")
    if quality is not None:
        f[5] = str(quality)
    if hdop is not None:
        f[7] = hdop
    return sentence(f"{fix.talker}GGA," + ",".join(f))


def shifted_north(fix: nmea.GgaFix, deg: float) -> bytes:
    return nmea.encode(nmea.build_gga(fix.time_s, fix.latitude_deg + deg, fix.longitude_deg, quality=fix.quality,
                                      hdop=fix.hdop, altitude_m=fix.altitude_m, talker=fix.talker))


def rewrite(src: Path, dst: Path, edit: Edit) -> Path:
    """Copy the log ``src`` to ``dst`` with every GGA fix (a position, before the dive or after surfacing)
    passed through ``edit``; metadata, attachments and every other frame as they were."""
    with MissionLogReader(src) as r:
        msgs = list(r.messages())
        meta = r.metadata()
        attachments = [(a, r.read_attachment(a)) for a in r.attachments()]
    ggas = [(i, nmea.decode(m.data)) for i, m in enumerate(msgs) if m.format == "nmea" and b"GGA" in m.data[:7]]
    no_fix = [k for k, (_, f) in enumerate(ggas) if not f.has_fix]  # type: ignore[union-attr]
    phase = {i: ("pre" if k < no_fix[0] else "post") for k, (i, f) in enumerate(ggas) if f.has_fix}  # type: ignore[union-attr]
    count = {"pre": 0, "post": 0}
    with MissionLogWriter(dst, flush_interval=0.0, fsync=False, software=False) as w:
        for name, record in meta.items():
            w.add_metadata(name, record)
        for a, blob in attachments:
            w.add_attachment(a.name, blob, a.media_type, a.log_time_ns, a.create_time_ns)
        for i, m in enumerate(msgs):
            if m.format is None:
                continue  # the truth topic (JSON): not read by the pipeline
            raw = m.data
            if i in phase:
                p = phase[i]
                raw = edit(nmea.decode(m.data), count[p], p)  # type: ignore[arg-type]
                count[p] += 1
            w(m.channel, m.format, m.log_time_ns, raw, m.t_sensor_ns)
    return dst


def no_site_config(log: Path, path: Path) -> Path:
    """The log's vehicle configuration without its ``[site]`` table (``replay --config``)."""
    with MissionLogReader(log) as r:
        text = r.metadata(decode_json=True)["vehicle_config"]["toml"]
    path.write_text(re.sub(r"\[site\]\nlatitude = [^\n]*\nlongitude = [^\n]*\n?", "", text))
    assert "[site]" not in path.read_text()
    return path


def replay(log: Path, out: Path, *extra: str) -> dict:
    assert main(["replay", str(log), "--out", str(out), "--quiet", "--no-classify", *extra]) == 0
    return json.loads((out / "summary.json").read_text())


def detections(out: Path) -> list[dict]:
    return [json.loads(x) for x in (out / "detections.jsonl").read_text().splitlines()]


@pytest.fixture(scope="module")
def mission(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict, list[dict]]:
    """The simulated log, and its untouched replay's summary and detections."""
    tmp = tmp_path_factory.mktemp("gnss_gating")
    log = tmp / "m.mcap"
    simulate_to_log(loads_scene(GNSS_SCENE), log, progress=False, workers=1)
    summary = replay(log, tmp / "out")
    assert summary["georef"]["georeferenced"] and summary["georef"].get("closure_refused") is None
    return log, summary, detections(tmp / "out")


def positions(dets: list[dict]) -> np.ndarray:
    return np.array([d["position_ned"] for d in dets])


# ---------------------------------------------------------------------------- decode
def test_decode_marks_latitude_91_5_as_implausible(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    raw = tmp_path / "gnss.nmea"
    raw.write_bytes(sentence("GPGGA,120000.00,9130.0000,N,12923.4900,E,1,10,0.9,5.0,M,20.0,M,,")
                    + sentence("GPGGA,120001.00,3602.4720,N,12923.4900,E,1,10,-5.0,5.0,M,20.0,M,,")
                    + sentence("GPGGA,120002.00,3602.4720,N,12923.4900,E,2,10,0.9,5.0,M,20.0,M,,"))
    assert main(["decode", str(raw), "--format", "nmea", "--jsonl"]) == 0
    rows = [json.loads(x) for x in capsys.readouterr().out.splitlines() if x.startswith("{")]
    recs = [r.get("record", r) for r in rows]
    assert [r["has_fix"] for r in recs] == [False, False, True], recs
    assert "latitude 91.5" in recs[0]["implausible"] and "HDOP -5" in recs[1]["implausible"]
    assert recs[2]["implausible"] is None


# ---------------------------------------------------------------------------- the datum, any values
fixes = st.builds(GnssPayload, st.floats(allow_nan=True, allow_infinity=True),
                  st.floats(allow_nan=True, allow_infinity=True), st.floats(-1e3, 1e3), st.integers(-3, 12),
                  st.floats(allow_nan=True, allow_infinity=True))


@settings(max_examples=200, deadline=None)
@given(st.lists(fixes, max_size=12))
def test_no_fix_stream_raises_or_makes_a_datum_alone(stream: list[GnssPayload]) -> None:
    """Any values (out of range, NaN, inf, any quality, any HDOP), no [site], a navigator without samples:
    nothing raises; a datum only from DATUM_FIXES usable fixes, and a plausible one."""
    geo = Georef(None, has_gnss=True)
    for k, fix in enumerate(stream):
        geo.on_fix(float(k), fix, CausalNavigator())
    usable = [f for f in stream if f.quality in (1, 2, 4, 5) and abs(f.latitude) <= 90 and abs(f.longitude) <= 180
              and not (np.isfinite(f.hdop) and f.hdop <= 0) and not np.isinf(f.hdop)]
    if geo.datum is not None:
        assert len(usable) >= DATUM_FIXES
        assert -90 <= geo.datum.latitude <= 90 and -180 <= geo.datum.longitude <= 180
    assert geo.summary()["fixes"]["received"] == len(stream) - len(geo._pending)


def test_datum_across_the_antimeridian_is_where_the_fixes_are() -> None:
    geo = Georef(None, has_gnss=True)
    for k, lon in enumerate((179.99995, -179.99995, 179.99990, -179.99990, 180.0, 179.99998)):
        geo.on_fix(float(k), GnssPayload(-16.5, lon, 0.0, 2, 0.8), CausalNavigator())
    assert geo.datum is not None and abs(abs(geo.datum.longitude) - 180.0) < 1e-4
    assert abs(geo.datum.latitude + 16.5) < 1e-6


def test_one_fix_is_never_the_datum() -> None:
    geo = Georef(None, has_gnss=True)
    nav = CausalNavigator()
    for k in range(DATUM_FIXES - 1):
        geo.on_fix(float(k), GnssPayload(36.0412, 129.3915, 0.0, 2, 0.8), nav)
    assert geo.datum is None  # 4 agreeing fixes: still none
    geo.on_fix(9.0, GnssPayload(36.0412, 129.3915, 0.0, 2, 0.8), nav)
    assert geo.datum is not None and "first 5" in str(geo.datum_source)


# ---------------------------------------------------------------------------- whole runs
@pytest.mark.slow
@pytest.mark.parametrize("field", ["lat", "lon"])
def test_one_wild_fix_without_site_is_not_the_datum_and_replay_writes_outputs(
        mission: tuple[Path, dict, list[dict]], tmp_path: Path, field: str) -> None:
    """The first fix at latitude 91.5 (or longitude 1e9), no [site]: counted implausible; the datum is the mean
    of the first good fixes; every output written, the detections where the good run puts them."""
    log, _, base_dets = mission
    def edit(f: nmea.GgaFix, k: int, p: str) -> bytes:
        if (k, p) != (0, "pre"):
            return nmea.encode(f)
        return gga(f, lat="9130.0000,N") if field == "lat" else gga(f, lon="1000000000.0,E")

    bad = rewrite(log, tmp_path / "bad.mcap", edit)
    cfg = no_site_config(log, tmp_path / "vehicle.toml")
    out = tmp_path / "out"
    summary = replay(bad, out, "--config", str(cfg))
    g = summary["georef"]
    assert g["fixes"]["implausible"] == 1 and g["georeferenced"]
    assert "first 5 GNSS fixes" in g["datum_source"]
    d = g["datum"]
    assert -90 <= d["latitude"] <= 90 and -180 <= d["longitude"] <= 180
    assert (out / "detections.geojson").is_file() and (out / "report.html").is_file()
    dets = detections(out)
    assert len(dets) == len(base_dets)
    lat = np.array([x["lat"] for x in dets]) - np.array([x["lat"] for x in base_dets])
    assert np.abs(lat).max() < 1e-5  # within 1 m of the good run's latitude


@pytest.fixture(scope="module")
def mixed_quality(mission: tuple[Path, dict, list[dict]], tmp_path_factory: pytest.TempPathFactory
                  ) -> tuple[dict, dict[str, int]]:
    """Before the dive, 3 of 4 fixes 30 m north of the truth: quality 6, quality 8 or HDOP -5."""
    log, _, _ = mission
    tmp = tmp_path_factory.mktemp("mixed_quality")
    sent = {"quality_estimated": 0, "quality_simulation": 0, "implausible": 0}

    def edit(f: nmea.GgaFix, k: int, p: str) -> bytes:
        if p != "pre" or k % 4 == 3:
            return nmea.encode(f)
        moved = nmea.decode(shifted_north(f, 30.0 / 111_000.0))
        assert isinstance(moved, nmea.GgaFix)
        key = ("quality_estimated", "quality_simulation", "implausible")[k % 4]
        sent[key] += 1
        return gga(moved, quality=6) if k % 4 == 0 else gga(moved, quality=8) if k % 4 == 1 else \
            gga(moved, hdop="-5.0")

    bad = rewrite(log, tmp / "bad.mcap", edit)
    return replay(bad, tmp / "out"), sent


@pytest.mark.slow
def test_quality_6_and_8_are_counted_by_kind_not_used(mission: tuple[Path, dict, list[dict]],
                                                      mixed_quality: tuple[dict, dict[str, int]]) -> None:
    _, base, _ = mission
    summary, sent = mixed_quality
    g = summary["georef"]
    # the anchor is the good quarter's: not pulled 30 m north by the fixes that are not measurements
    assert np.linalg.norm(np.subtract(g["start_anchor_ne_m"], base["georef"]["start_anchor_ne_m"])) < 1.0
    assert sent["quality_estimated"] >= 3 and sent["quality_simulation"] >= 3
    assert g["fixes"]["quality_estimated"] == sent["quality_estimated"]
    assert g["fixes"]["quality_simulation"] == sent["quality_simulation"]


@pytest.mark.slow
def test_hdop_minus_5_is_rejected(mixed_quality: tuple[dict, dict[str, int]]) -> None:
    summary, sent = mixed_quality
    assert sent["implausible"] >= 3 and summary["georef"]["fixes"]["implausible"] == sent["implausible"]


@pytest.mark.slow
@pytest.mark.parametrize("phase", ["post", "pre"])
def test_a_10_km_closure_is_refused_and_reported_detections_stay_on_the_dead_reckoned_track(
        mission: tuple[Path, dict, list[dict]], tmp_path: Path, capsys: pytest.CaptureFixture[str],
        phase: str) -> None:
    """Every fix after surfacing (or before the dive) 10 km north, after a 40 m line: the closure (10 km) is
    far beyond what navigation drifts over the mission: refused (summary.json, the report, one stderr line), no
    correction; the detections sit on the dead-reckoned track with the start anchor, not moved kilometres."""
    log, base, base_dets = mission
    bad = rewrite(log, tmp_path / "bad.mcap",
                  lambda f, k, p: shifted_north(f, DEG_10_KM) if p == phase else nmea.encode(f))
    capsys.readouterr()
    out = tmp_path / "out"
    summary = replay(bad, out)
    err = [x for x in capsys.readouterr().err.splitlines() if "closure refused" in x]
    assert len(err) == 1, err
    g = summary["georef"]
    refused = g["closure_refused"]
    assert refused is not None and abs(refused["closure_m"] - 10_000.0) < 100.0 and refused["bound_m"] < 100.0
    assert g["closure_m"] is None and g["correction"].startswith("refused")
    assert g["fixes"]["beyond_dead_reckoning"] == refused["fixes"] >= 3
    assert "closure refused" in (out / "report.html").read_text()
    dets = detections(out)
    assert len(dets) == len(base_dets)
    assert all(d["drift_correction_ne"] == [0.0, 0.0] for d in dets)
    # where the good run put them, but for its (sub-metre) correction and the start anchor's move (10 km when
    # the fixes before the dive are the ones moved: GNSS alone cannot tell which set is wrong)
    anchor_move = np.subtract(g["start_anchor_ne_m"], base["georef"]["start_anchor_ne_m"])
    base_pos = positions(base_dets)[:, :2] - np.array([d["drift_correction_ne"] for d in base_dets])
    assert np.abs(positions(dets)[:, :2] - base_pos - anchor_move).max() < 0.05
    assert np.linalg.norm(anchor_move) < 1.0 if phase == "post" else abs(anchor_move[0] - 10_000.0) < 100.0
