"""Viewer-ready results (issue 17): ``DIR/results.mcap`` of a replay decodes with the schemas it carries
and says the right things; ``log export`` writes the replay's navigation and a subsampled set of fans;
detections carry their orientation; PLY files carry object id and time, in NED or z-up."""

from __future__ import annotations

import csv
import io
import json
import math
from collections import Counter, defaultdict
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from google.protobuf.descriptor_pb2 import FileDescriptorSet
from hypothesis import given, settings
from hypothesis import strategies as st
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory as ProtobufDecoderFactory
from PIL import Image
from small_mission import SmallMissionRun

from auvlink.cli import main
from auvlink.pipeline.outputs import write_points_ply
from auvlink.pipeline.results import Detection, MissionResult, Poses
from auvlink.pipeline.results_mcap import NO_DATUM, cloud_steps, geodetic_track, local_to_geodetic
from auvlink.pipeline.setup import MissionSetup
from auvlink.validation import Site
from logs_format import MissionLogReader
from recon.shape import oriented_box

TOPICS = {
    "/tf": "foxglove.FrameTransforms", "/nav/pose": "foxglove.PoseInFrame",
    "/nav/track": "foxglove.PosesInFrame", "/nav/location": "foxglove.LocationFix",
    "/objects/cloud": "foxglove.PointCloud", "/objects/detections": "foxglove.SceneUpdate",
    "/sonar/fan": "foxglove.CompressedImage",
}


@pytest.fixture(scope="module")
def replayed(small_mission_run: SmallMissionRun) -> tuple[Path, Path]:
    """The small mission's log and its replay folder (replayed once per session)."""
    return small_mission_run.log, small_mission_run.out


def decoded(path: Path) -> tuple[dict[str, list[tuple[int, Any]]], dict[str, Any], dict[str, dict[str, str]]]:
    """Every message of an MCAP file decoded with the schemas it carries (protobuf decoder factory)."""
    by_topic: dict[str, list[tuple[int, Any]]] = defaultdict(list)
    schemas: dict[str, Any] = {}
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[ProtobufDecoderFactory()])
        for schema, channel, message, msg in reader.iter_decoded_messages():
            by_topic[channel.topic].append((message.log_time, msg))
            schemas[channel.topic] = schema
        meta = {m.name: dict(m.metadata) for m in reader.iter_metadata()}
    return by_topic, schemas, meta


@pytest.mark.slow
def test_results_mcap_decodes_every_channel_with_its_schemas(replayed: tuple[Path, Path]) -> None:
    log, out = replayed
    msgs, schemas, meta = decoded(out / "results.mcap")
    assert {t: s.name for t, s in schemas.items()} == TOPICS
    for topic, schema in schemas.items():  # the package's compiled descriptors, not hand-made schemas
        assert schema.encoding == "protobuf"
        fds = FileDescriptorSet.FromString(schema.data)
        assert any(f.package == "foxglove" and schema.name.split(".")[1] in [m.name for m in f.message_type]
                   for f in fds.file), topic
    with MissionLogReader(log) as r:  # one time line with the mission log
        lo, hi = r.start_ns, r.end_ns
    assert lo is not None and hi is not None
    for topic, items in msgs.items():
        assert all(lo - 10**9 <= t <= hi + 10**9 for t, _ in items), topic
    assert meta["auvlink_results"]["location_frame"] == NO_DATUM

    # transforms: map -> world (static, NED under ENU), world -> base_link (the pose), base_link -> sonar
    tf_t, tfs = msgs["/tf"][len(msgs["/tf"]) // 2]
    pairs = {(t.parent_frame_id, t.child_frame_id): t for t in tfs.transforms}
    assert set(pairs) == {("map", "world"), ("world", "base_link"), ("base_link", "sonar"), ("map", "ned")}
    q = pairs[("map", "world")].rotation
    assert (q.x, q.y, q.z, q.w) == pytest.approx((math.sqrt(0.5), math.sqrt(0.5), 0, 0))
    pose = dict(msgs["/nav/pose"])[tf_t].pose.position
    tr = pairs[("world", "base_link")].translation
    assert (tr.x, tr.y, tr.z) == (pose.x, pose.y, pose.z)
    north = [m.pose.position.x for _, m in msgs["/nav/pose"]]
    assert min(north) < 1.0 and max(north) > 38.0  # the 40 m line, 10 Hz
    assert 10 <= len(msgs["/nav/pose"]) / ((msgs["/nav/pose"][-1][0] - msgs["/nav/pose"][0][0]) * 1e-9) <= 10.5

    # location: datum-less, the track's offsets from 0 N 0 E, said in the frame id and the metadata
    fixes = msgs["/nav/location"]
    assert all(f.frame_id == NO_DATUM and f.metadata[0].key == "notice" for _, f in fixes)
    assert 0.9 <= len(fixes) / len(msgs["/nav/pose"]) * 10 <= 1.1  # 1 Hz
    poses = dict(msgs["/nav/pose"])
    ned = np.array([[poses[t].pose.position.x, poses[t].pose.position.y, 0.0] for t, _ in fixes])
    lat, lon = local_to_geodetic(ned, 0.0, 0.0)
    assert [(f.latitude, f.longitude) for _, f in fixes] == list(zip(lat.tolist(), lon.tolist(), strict=True))
    assert all(abs((f.heading + 180) % 360 - 180) < 5 for _, f in fixes)  # the line runs north
    assert lat.max() == pytest.approx(ned[:, 0].max() / 6335439.0 * 180 / math.pi, rel=1e-3)  # meridian radius at 0 N

    # detections: one cube + label per object, oriented like the object (the pipe lies at 60 deg)
    dets = [json.loads(line) for line in (out / "detections.jsonl").read_text().splitlines()]
    assert len(dets) == 2
    updates = [upd for _, upd in msgs["/objects/detections"]]
    assert [len(u.entities) for u in updates] == [1, 2]  # each update: every object so far (seeking works)
    ents = {e.id: e for e in updates[-1].entities}
    assert set(ents) == {f"object_{d['id']}" for d in dets}
    pipe = next(d for d in dets if d["class"] == "pipe")
    assert abs(pipe["yaw_deg"] - 60.0) < 8.0 and pipe["length_m"] > 2 * pipe["width_m"]
    cube = ents[f"object_{pipe['id']}"].cubes[0]
    yaw = math.degrees(2 * math.atan2(cube.pose.orientation.z, cube.pose.orientation.w))
    assert yaw == pytest.approx(pipe["yaw_deg"], abs=0.01)
    assert (cube.size.x, cube.size.y) == pytest.approx((pipe["length_m"], pipe["width_m"]), abs=1e-3)
    assert ents[f"object_{pipe['id']}"].texts[0].text.startswith(f"#{pipe['id']} pipe ")

    # the object cloud: x, y, z, object id, time; the last message holds every object's points
    cloud = msgs["/objects/cloud"][-1][1]
    names = [f.name for f in cloud.fields]
    assert names == ["x", "y", "z", "object_id", "time"] and cloud.frame_id == "world"
    rec = np.frombuffer(cloud.data, dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("object_id", "<u4"),
                                           ("time", "<f4")])
    assert Counter(rec["object_id"].tolist()) == {d["id"]: d["n_points"] for d in dets}
    t0 = min(t for t, _ in msgs["/nav/pose"]) * 1e-9
    for d in dets:
        t = rec["time"][rec["object_id"] == d["id"]]
        assert d["t_first"] - t0 - 0.5 <= t.min() <= t.max() <= d["t_last"] - t0 + 0.5

    # the sonar fan: ~1 frame/s, PNG, highlight returns marked on the frames that saw the objects
    fans = [m for _, m in msgs["/sonar/fan"]]
    assert len(fans) == 27 and all(m.format == "png" for m in fans)  # 267 frames at 10 Hz: every 10th
    cyan = []
    for m in fans:
        img = np.asarray(Image.open(io.BytesIO(m.data)).convert("RGB"))
        cyan.append(int(np.all(img == (0, 255, 255), axis=2).sum()))
    assert img.shape[0] == 256 and max(cyan) > 50 and sorted(cyan)[len(cyan) // 2] < max(cyan) / 3
    assert (out / "results.mcap").stat().st_size < 4_000_000


def test_the_shipped_layout_names_only_topics_the_file_has() -> None:
    layout = json.loads((Path(__file__).resolve().parents[1] / "docs" / "foxglove_layout.json").read_text())
    used: set[str] = set()

    def walk(v: Any) -> None:
        if isinstance(v, dict):
            for k, x in v.items():
                if k.startswith("/"):
                    used.add(k)
                walk(x)
        elif isinstance(v, list):
            for x in v:
                walk(x)
        elif isinstance(v, str) and v.startswith("/") and "Topic" not in v:
            used.add(v.split(".")[0])

    for panel in layout["configById"].values():
        walk({k: v for k, v in panel.items() if k != "publish"})
    assert used and used <= set(TOPICS), used - set(TOPICS)
    panels = [k.split("!")[0] for k in layout["configById"]]
    assert {"3D", "Image", "map", "Plot"} <= set(panels)


@pytest.mark.slow
def test_ply_files_carry_object_id_and_time(replayed: tuple[Path, Path]) -> None:
    _, out = replayed
    dets = [json.loads(line) for line in (out / "detections.jsonl").read_text().splitlines()]
    for d in dets:
        head, rec = read_ply(out / d["cloud"])
        assert "comment auvlink recon, world frame NED (m)" in head
        assert set(rec["object_id"].tolist()) == {d["id"]} and len(rec) == d["n_points"]
        assert d["t_first"] - 0.5 <= rec["time"].min() <= rec["time"].max() <= d["t_last"] + 0.5
        assert np.mean(rec["x"]) == pytest.approx(d["position_ned"][0], abs=1.0)
    _, cloud = read_ply(out / "cloud.ply")
    assert Counter(cloud["object_id"].tolist()) == {d["id"]: d["n_points"] for d in dets}


def read_ply(path: Path) -> tuple[str, np.ndarray]:
    data = path.read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    head = data[:end].decode()
    kinds = {"double": "<f8", "uint": "<u4", "uchar": "u1"}
    fields = [(ln.split()[2], kinds[ln.split()[1]]) for ln in head.splitlines() if ln.startswith("property")]
    return head, np.frombuffer(data[end:], dtype=fields)


def test_zup_ply_is_east_north_up(tmp_path: Path) -> None:
    pts = np.array([[10.0, 2.0, 20.0], [11.0, 2.5, 19.5]])
    det = Detection(3, "pipe", 0.9, (10.5, 2.25, 19.75), (1, 0.5, 0.5), 2, 100.0, 101.0, pts,
                    times=np.array([100.0, 101.0]))
    write_points_ply(tmp_path / "z.ply", [det], "zup")
    head, rec = read_ply(tmp_path / "z.ply")
    assert "x east, y north, z up" in head
    assert np.column_stack([rec["x"], rec["y"], rec["z"]]).tolist() == [[2.0, 10.0, -20.0], [2.5, 11.0, -19.5]]
    assert rec["object_id"].tolist() == [3, 3] and rec["time"].tolist() == [100.0, 101.0]
    assert main(["replay", str(tmp_path / "none.mcap"), "--out", str(tmp_path / "o"), "--ply-frame", "zup"]) == 1


def test_location_uses_the_georeferenced_track_else_says_it_has_none() -> None:
    poses = Poses(np.array([0.0, 1.0]), np.array([[0.0, 0.0, 10.0], [100.0, 0.0, 10.0]]),
                  np.array([[0, 0, 0, 1.0], [0, 0, 0, 1.0]]))
    site = Site(latitude=36.0, longitude=129.5)  # a datum without GNSS fixes does not georeference a run
    result = MissionResult(log=None, setup=MissionSetup(site=site), detections=[], track=np.zeros((0, 3)),
                           t0_ns=10**18, poses=poses)
    geo = geodetic_track(result)
    assert geo.frame_id == NO_DATUM and geo.t_ns.tolist() == [10**18, 10**18 + 10**9]
    assert geo.lat[0] == 0.0 and geo.lon.tolist() == [0.0, 0.0]
    assert geo.lat[1] * 110_574 == pytest.approx(100.0, rel=1e-4)  # 110.574 km per degree of latitude at 0 N
    # the georeferenced track (datum + GNSS, drift-corrected), where the run has one
    result.track_info = {"time": np.array([5.0, 6.0]), "lat": np.array([np.nan, 36.1]),
                         "lon": np.array([129.0, 129.6]), "depth": np.array([1.0, 2.0]), "heading": np.array([0, 90.0])}
    geo = geodetic_track(result)
    got = (geo.frame_id, geo.t_ns.tolist(), geo.lat.tolist(), geo.heading.tolist())
    assert got == ("wgs84", [6 * 10**9], [36.1], [90.0])


def test_cloud_steps_keep_the_cumulative_clouds_within_the_budget() -> None:
    assert cloud_steps([]) == [] and cloud_steps([10, 10, 10]) == [0, 1, 2]
    sizes = [1000] * 100  # 100 objects of 1000 points: all cumulative clouds would be 101 MB
    idx = cloud_steps(sizes, budget=16 << 20)
    assert idx[-1] == 99 and len(idx) > 10
    assert sum((i + 1) * 1000 * 20 for i in idx) <= 16 << 20
    step = idx[1] - idx[0]
    assert sum((i + 1) * 20_000 for i in sorted({*range(step - 2, 100, step - 1), 99})) > 16 << 20  # the smallest


def test_oriented_box_golden() -> None:
    rng = np.random.default_rng(0)
    along = rng.uniform(-2, 2, 400)
    across = rng.uniform(-0.25, 0.25, 400)
    yaw = math.radians(130.0)  # an axis: reported in [0, 180)
    n = 5 + along * math.cos(yaw) - across * math.sin(yaw)
    e = -3 + along * math.sin(yaw) + across * math.cos(yaw)
    box = oriented_box(np.column_stack([n, e, rng.uniform(9, 10, 400)]))
    assert box.yaw_deg == pytest.approx(130.0, abs=1.0)
    assert box.length_m == pytest.approx(4.0, abs=0.05) and box.width_m == pytest.approx(0.5, abs=0.05)
    assert box.centre[:2] == pytest.approx((5, -3), abs=0.05)
    assert oriented_box(np.zeros((0, 3))).length_m == 0.0


@settings(max_examples=60, deadline=None)
@given(st.floats(0, 360), st.floats(-50, 50), st.floats(-50, 50), st.integers(0, 2**31))
def test_oriented_box_turns_and_moves_with_its_points(turn: float, dn: float, de: float, seed: int) -> None:
    """Turning the points about the vertical by ``turn`` deg turns the yaw by ``turn`` (mod 180) and keeps
    the spans; moving them moves the centre: the box belongs to the object, not to the axes."""
    rng = np.random.default_rng(seed)
    pts = np.column_stack([rng.uniform(-2, 2, 60), rng.uniform(-0.4, 0.4, 60), rng.uniform(9, 10, 60)])
    a = math.radians(turn)
    rot = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])
    b0, b1 = oriented_box(pts), oriented_box(pts @ rot.T + [dn, de, 0])
    assert ((b1.yaw_deg - b0.yaw_deg - turn + 90) % 180 - 90) == pytest.approx(0, abs=1e-6)
    assert (b1.length_m, b1.width_m, b1.height_m) == pytest.approx((b0.length_m, b0.width_m, b0.height_m), abs=1e-9)
    c0 = rot @ np.asarray(b0.centre) + [dn, de, 0]
    assert np.allclose(b1.centre, c0, atol=1e-9) and 0 <= b1.yaw_deg < 180 and b1.length_m >= b1.width_m


@pytest.mark.slow
def test_log_export_navigation_is_the_replay_track_and_fans_are_subsampled(
        replayed: tuple[Path, Path], tmp_path: Path) -> None:
    log, out = replayed
    exp = tmp_path / "exp"
    assert main(["log", "export", str(log), "--out", str(exp)]) == 0
    rows = list(csv.DictReader((exp / "navigation.csv").open()))
    assert list(rows[0]) == ["t_utc_s", "t_s", "lat_deg", "lon_deg", "north_m", "east_m", "down_m", "roll_deg",
                             "pitch_deg", "yaw_deg", "altitude_m"]
    assert rows[0]["lat_deg"] == "" and rows[0]["lon_deg"] == ""  # no GNSS in this mission: no lat/lon
    nav = {round(float(r["t_utc_s"]) * 1e3): [float(r[k]) for k in ("north_m", "east_m", "down_m")] for r in rows}
    msgs, _, _ = decoded(out / "results.mcap")
    diffs = [np.subtract(nav[round(t * 1e-6)], [m.pose.position.x, m.pose.position.y, m.pose.position.z])
             for t, m in msgs["/nav/pose"] if round(t * 1e-6) in nav]
    assert len(diffs) >= 0.95 * len(msgs["/nav/pose"])
    assert np.abs(diffs).max() < 1e-5  # the replay's own solution (the CSV rounds to 1 um)
    with MissionLogReader(log) as r:
        frames = sum(1 for _ in r.messages(channels=["sonar"]))
    pngs = sorted((exp / "sonar").glob("frame_*.png"))
    assert len(pngs) == math.ceil(frames / 25) and pngs[1].name == "frame_000025.png"
    assert main(["log", "export", str(log), "--out", str(tmp_path / "e2"), "--every", "0"]) == 1
