"""What the conformance suite (``tests/test_conformance.py``) knows about each registered wire format.

One :class:`Entry` per name in :func:`auvlink.formats.names`; adding a format is adding one entry here
(and its golden file under ``tests/golden/<format>/``, see ``tests/golden/README.md``). A registered
format without an entry fails every conformance test with a message that says so.

A golden file is a frame stream exactly as a port delivers it (after ``skip`` leading bytes, e.g. an
ARIS file header). ``expect`` maps a frame index to values of the format's ``to_json`` (SI units,
the public JSON of ``auvlink decode --jsonl``): numbers compare within ``abs_tol``/``rel_tol``, lists
element-wise, anything else exactly. Paths ``"shared:..."`` are real captures in ``../shared/data``
(the test is skipped when that folder is absent); other paths are relative to ``tests/golden``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

PSI = 6894.757293168361  # Pa per psi
G = 9.80665  # m/s^2 per g (the KVH accelerometers' unit)


@dataclass(frozen=True)
class Golden:
    """One golden frame stream and the facts known about it."""

    path: str
    source: str  # where the bytes come from (capture, manual, published vector)
    frames: int | None  # whole frames the format's framer finds in the stream (None: not checked)
    expect: dict[int, dict[str, Any]]
    skip: int = 0  # leading bytes that are not part of the frame stream (a file header)
    dropped: int | None = None  # bytes the framer drops (None: not checked)
    bad_checksums: int = 0  # frames the framer rejected for their checksum
    abs_tol: float = 0.0
    rel_tol: float = 1e-9


@dataclass(frozen=True)
class Entry:
    """The conformance data of one format."""

    goldens: tuple[Golden, ...]
    #: worst-case false starts: byte patterns that look like the start of a frame to the framer (sync
    #: bytes, plausible headers that fail later checks); interleaved with real frames they must cost none
    decoys: tuple[bytes, ...]
    #: substrings that random gaps between frames must not contain: a format without a checksum cannot
    #: tell a false start in garbage from a frame cut short (documented limit, not a framer bug)
    gap_excludes: tuple[bytes, ...] = ()
    #: the frames carry a checksum or CRC: a damaged frame is never emitted, and costs no other frame
    checksum: bool = False
    #: at most this many golden frames in a fuzzed stream (large sonar frames keep the tests fast)
    stream_frames: int = 8
    notes: str = field(default="", compare=False)


def _deg(x: float) -> float:
    return math.radians(x)


PD0_WITH_BT = Golden(
    "shared:rdi/RDI_withBT.000",
    "RDI Workhorse 600 kHz capture (MHKiT examples, BSD-3); facts in shared/data/README.md",
    frames=1721,
    expect={
        0: {"coordinate_system": "earth", "firmware": "51.41", "ensemble_number": 1},
        507: {"bt_velocity_mps": [0.052, 0.062, 0.091, -0.003], "bt_range_m": [6.86, 10.39, 7.53, 9.05]},
    },
    abs_tol=5e-4,
)

TABLE: dict[str, Entry] = {
    "pd0": Entry(
        goldens=(
            PD0_WITH_BT,
            Golden("shared:rdi/RDI_test01.000", "RDI beam-coordinate capture with a 772-byte cut tail", frames=22,
                   dropped=772, expect={0: {"coordinate_system": "beam", "n_cells": 36, "cell_size_m": 0.5,
                                            "bt_velocity_mps": [None] * 4}}),
            Golden("shared:rdi/winriver01.PD0", "WinRiver river transect, ship coordinates", frames=None,
                   expect={0: {"coordinate_system": "ship", "bt_velocity_mps": [0.186, -0.994, -0.05, -0.004],
                               "bt_range_m": [41.71, 39.26, 41.30, 40.90]}}, abs_tol=5e-4),
            Golden("shared:rdi/adcp_auv_51.pd0", "AUV-mounted Workhorse fw 19.13 (OOI mi-dataset, BSD)", frames=51,
                   dropped=0, expect={0: {"firmware": "19.13", "time": "2014-12-19T17:17:55.940Z",
                                          "bt_velocity_mps": [-0.058, -0.137, 0.012, -0.003],
                                          "bt_range_m": [14.23, 14.26, 13.69, 14.81]}}, abs_tol=5e-4),
            Golden("shared:rdi/adcp_auv_3.pd0", "AUV-mounted Workhorse fw 19.13 (OOI mi-dataset, BSD)", frames=None,
                   expect={0: {"firmware": "19.13"}}),
            Golden("shared:rdi/winriver02.PD0", "WinRiver transect with GPS data types", frames=75, dropped=0,
                   expect={0: {"coordinate_system": "ship"}}),
            Golden("shared:rdi/RDI_7f79.000", "ensembles mixed with 0x7F79 waves records (skipped, dropped)",
                   frames=60, expect={0: {"ensemble_number": 1}, 59: {"ensemble_number": 60}}),
            Golden("shared:rdi/ND072023.PD0", "glider PD0, fw 34.12, 58-byte fixed leader", frames=54,
                   expect={0: {"firmware": "34.12"}}),
            Golden("shared:rdi/LB180210_3_corrupted.PD0", "a deliberately corrupted glider PD0: keep the good",
                   frames=2, dropped=446, bad_checksums=1, expect={}),
        ),
        decoys=(b"\x7f\x7f", b"\x7f\x7f\xfe\xff\x00\x01\x08\x00", b"\x7f\x79\x40\x00\x00\x01\x08\x00"),
        checksum=True,
        stream_frames=6,
    ),
    "pd6": Entry(
        goldens=(Golden(
            "pd6/workhorse_manual.pd6", "one ensemble of PD6 lines in the WorkHorse manual's field layout", frames=10,
            dropped=0,
            expect={
                0: {"type": "SA", "pitch_deg": -2.31, "roll_deg": 1.96, "heading_deg": 212.78},
                1: {"type": "TS", "time": "2004-08-11T11:56:36.440Z", "salinity_ppt": 35.0, "temperature_c": 21.0,
                    "depth_m": 0.0, "speed_of_sound_mps": 1524.0, "bit_result": 0},
                2: {"type": "WI", "velocity_mps": [None, None, None], "valid": False},
                3: {"type": "BI", "frame": "instrument", "velocity_mps": [0.024, -0.039, 0.016],
                    "error_velocity_mps": 0.002, "valid": True},
                7: {"type": "BE", "frame": "earth", "velocity_mps": [0.043, -0.018, 0.016], "error_velocity_mps": None},
                9: {"type": "BD", "east_m": 0.45, "north_m": -0.19, "up_m": 0.16, "range_m": 20.89,
                    "time_since_good_s": 0.06},
            },
        ),),
        decoys=(b":", b":BI,", b":SA, -2.31\r"),
    ),
    "dsp1760": Entry(
        goldens=(Golden(
            "dsp1760/kvh_published.bin", "KVH DSP-1750/1760 published message (CRC 0x4BFA34D8)", frames=1, dropped=0,
            expect={0: {"mode": "rate", "gyro": [2.0196e-5, 5.1599e-5, -1.3111e-5],
                        "accel_m_s2": [-1.00191 * G, -0.003495 * G, 0.002109 * G], "status": 0x77, "sequence": 61,
                        "temperature_c": 40, "gyro_valid": [True] * 3}},
            rel_tol=1e-4,
        ),),
        decoys=(b"\xfe\x81\xff\x55", b"\xfe\x81\xff\x55" + bytes(20)),
        checksum=True,
    ),
    "dsp3000": Entry(
        goldens=(Golden("dsp3000/kvh_published.txt", "KVH DSP-3000 published line", frames=1, dropped=0,
                        expect={0: {"mode": "rate", "value": _deg(0.015733), "unit": "rad/s", "valid": True}}),),
        decoys=(b"12.5", b"\r\n", b"  1\r\n", b"0.000001   1"),
    ),
    "dsp3000_incremental": Entry(
        goldens=(Golden("dsp3000/kvh_published.txt", "KVH DSP-3000 published line (incremental-angle unit)",
                        frames=1, dropped=0,
                        expect={0: {"mode": "incremental", "value": _deg(0.015733), "unit": "rad"}}),),
        decoys=(b"12.5", b"\r\n", b"  1\r\n"),
    ),
    "dsp3000_integrated": Entry(
        goldens=(Golden("dsp3000/kvh_published.txt", "KVH DSP-3000 published line (integrated-angle unit)",
                        frames=1, dropped=0,
                        expect={0: {"mode": "integrated", "value": _deg(0.015733), "unit": "rad"}}),),
        decoys=(b"12.5", b"\r\n", b"  1\r\n"),
    ),
    "keller": Entry(
        goldens=(Golden(
            "keller/session.bin",
            "Keller bus: the published CRC vector 02 30 C4 00, then a hand-built F48/F73 session (bar, degC)",
            frames=7, dropped=0,
            expect={
                0: {"type": "init_request", "address": 2},
                2: {"type": "init_response", "address": 1, "device_class": 5, "group": 20, "year": 14, "week": 33,
                    "buffer": 10, "status": 0},
                3: {"type": "read_request", "address": 1, "channel": 1, "channel_name": "P1"},
                4: {"type": "read_response", "address": 1, "value": 1.5, "status": 0},
                5: {"type": "read_request", "channel": 4, "channel_name": "TOB1"},
                6: {"type": "read_response", "value": 21.25},
            },
        ),),
        decoys=(b"\x01\x30", b"\x01\x49\x01", b"\x49"),
        checksum=True,
    ),
    "paro": Entry(
        goldens=(Golden(
            "paro/digiquartz_published.txt", "Paroscientific Digiquartz published lines", frames=2, dropped=0,
            expect={
                0: {"type": "reading", "destination": 0, "source": 1, "value": 2991.11891, "unit": "psi",
                    "pressure_pa": 2991.11891 * PSI, "temperature_c": None},
                1: {"type": "response", "command": "P4", "values": [16.7509, 23.01532],
                    "pressure_pa": 16.7509 * PSI, "temperature_c": 23.01532},
            },
        ),),
        decoys=(b"*", b"*00", b"*0001", b"\r\n"),
    ),
    "aris": Entry(
        goldens=(Golden(
            "shared:aris/sample.aris", "Sound Metrics ARIS SDK sample (MIT); 1024-byte file header skipped",
            frames=6, dropped=0, skip=1024,
            expect={
                0: {"frame_index": 0, "ping_mode": 1, "beams": 48, "samples": 2000, "sound_speed": 1435.93,
                    "window_start_m": 4593e-6 * 1435.93 / 2, "window_length_m": 2000 * 14e-6 * 1435.93 / 2,
                    "azimuth_min_rad": _deg(-7.339), "azimuth_max_rad": _deg(7.339), "time": 1371198079.122519},
                5: {"frame_index": 5, "beams": 48, "samples": 2000},
            },
            abs_tol=1e-2, rel_tol=1e-5,
        ),),
        decoys=(b"DDF\x05",),
        gap_excludes=(b"DDF\x05",),
        stream_frames=3,
    ),
    "didson": Entry(
        goldens=(Golden(
            "didson/frames.bin",
            "DIDSON-class frames (96 beams, ARIS header); no public capture exists: frozen from didson.build, "
            "values hand-derived from the header fields (tests/golden/README.md)",
            frames=3, dropped=0,
            expect={
                0: {"frame_index": 0, "ping_mode": 3, "beams": 96, "samples": 16, "sound_speed": 1480.0,
                    "window_start_m": 2.5, "window_length_m": 10.0, "range_min_m": 2.5,
                    "range_max_m": 2.5 + 15 * 10.0 / 16, "azimuth_min_rad": _deg(-14.5),
                    "azimuth_max_rad": _deg(14.5), "time": 1_700_000_000.25, "heading": _deg(350.0),
                    "pitch": -0.1, "roll": 0.02},
                2: {"frame_index": 2, "time": 1_700_000_000.45, "heading": None},
            },
            abs_tol=1e-6, rel_tol=1e-6,
        ),),
        decoys=(b"DDF\x05",),
        gap_excludes=(b"DDF\x05",),
        stream_frames=3,
    ),
    "can": Entry(
        goldens=(Golden(
            "can/nav_frames.bin", "raw CAN frames built by hand from auvlink/data/auvlink_nav.dbc (scale, offset)",
            frames=4, dropped=0,
            expect={
                0: {"arbitration_id": 0x120, "name": "DVL_BT_VELOCITY",
                    "signals": {"vx": 1.234, "vy": -0.5, "vz": 0.001, "counter": 7.0, "valid": 1.0}},
                1: {"arbitration_id": 0x141, "name": "DEPTH", "signals": {"depth": 37.5, "counter": 3.0, "valid": 1.0}},
                2: {"name": "GYRO_RATE", "signals": {"rate_z": -0.0123, "counter": 9.0, "valid": 1.0}},
                3: {"name": "ATTITUDE", "signals": {"heading": 3.0, "pitch": -0.05, "roll": 0.1, "valid": 1.0}},
            },
            abs_tol=1e-9,
        ),),
        decoys=(b"\xa5\x5a",),
        gap_excludes=(b"\xa5\x5a",),
    ),
    "oculus": Entry(
        goldens=(Golden(
            "shared:oculus/one_ping_8bit.raw", "Blueprint Oculus M1200d ping (liboculus test data, BSD-3); facts in "
            "shared/data/README.md", frames=1, dropped=0,
            expect={0: {"type": "simple_ping_result", "ping_id": 415323, "n_beams": 256, "n_ranges": 703,
                        "bearing_min_rad": _deg(-30.0), "bearing_max_rad": _deg(30.0), "frequency_hz": 2098880.6,
                        "range_resolution_m": 0.0028421889710794315, "speed_of_sound_mps": 1490.658551265436,
                        "range_demand_m": 2.0, "gain_percent": 50.0, "image_offset": 2048, "image_size": 179968,
                        "row_gain": False, "image_mean": 55.857}},
            abs_tol=0.05, rel_tol=1e-9,
        ),),
        decoys=(b"SO", b"SO\x00\x00\x00\x00\x23\x00\x00\x00"),
        gap_excludes=(b"SO",),
        stream_frames=3,
    ),
    # NMEA 0183 (added on the geo branch): the entry applies once ``nmea`` is registered
    "nmea": Entry(
        goldens=(
            Golden(
                "nmea/atomic2020_rhb_gps.nmea",
                "NOAA R/V Ronald H. Brown DGPS (VS100), ATOMIC 2020 (tests/golden/nmea/README.md)", frames=29,
                dropped=0,
                expect={
                    1: {"type": "GGA", "talker": "GP", "time_s": 19 * 3600 + 59 * 60 + 59.0,
                        "latitude_deg": 15 + 41.31258893 / 60, "longitude_deg": -(51 + 30.51204125 / 60),
                        "quality": 2, "satellites": 6, "hdop": 1.5, "altitude_m": 9.2, "geoid_separation_m": -37.6,
                        "dgps_age_s": 4.0, "has_fix": True},
                    5: {"type": "RMC", "valid": True, "latitude_deg": 15 + 41.31258893 / 60,
                        "longitude_deg": -(51 + 30.51204125 / 60), "speed_mps": 0.26 * 1852 / 3600,
                        "course_rad": math.radians(147.44)},
                },
                rel_tol=1e-9, abs_tol=1e-9,
            ),
            Golden("nmea/ublox_neo6m_nofix.nmea", "u-blox NEO-6M before its first fix (tests/golden/nmea/README.md)",
                   frames=6, dropped=0,
                   expect={0: {"type": "RMC", "valid": False, "has_fix": False},
                           2: {"type": "GGA", "quality": 0, "satellites": 0, "has_fix": False}}),
        ),
        decoys=(b"$", b"$GPGGA,", b"*7E\r\n", b"!"),
        checksum=True,
    ),
}
