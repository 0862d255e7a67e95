"""A checkpoint is data (issue 34): every field is checked before any network is built, and a bad one is one
:class:`CheckpointError` line naming the field and what is allowed; the CLI shows it as ``auvlink: error: ...``
without a traceback. The bad checkpoints are the shipped one with one field changed."""

from __future__ import annotations

import copy
import math
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import torch

from auvlink.cli import main
from classify.checkpoint import load_checkpoint, read_checkpoint, save_checkpoint
from classify.checkpoint_meta import MAX_WIDTH
from classify.errors import CheckpointError
from classify.infer import DEFAULT_MODEL, Classifier

Edit = Callable[[dict[str, Any]], object]


@pytest.fixture(scope="module")
def shipped() -> dict[str, Any]:
    doc: dict[str, Any] = torch.load(DEFAULT_MODEL, weights_only=True)
    return doc


def _bad(tmp_path: Path, shipped: dict[str, Any], edit: Edit, name: str = "bad.pt") -> Path:
    doc = copy.deepcopy(shipped)
    edit(doc)
    path = tmp_path / name
    torch.save(doc, path)
    return path


def _names(names: list[Any]) -> Edit:
    return lambda d: d.__setitem__("class_names", names)


def _set(table: str, key: str, value: Any) -> Edit:
    return lambda d: d[table].__setitem__(key, value)


def _nested(depth: int) -> list[Any]:
    out: list[Any] = [1]
    for _ in range(depth):
        out = [out]
    return out


SHIPPED_NAMES = ["reef_a", "reef_b", "reef_c", "sphere", "hemisphere", "pipe", "half_pipe", "box", "clutter"]
CASES: dict[str, tuple[Edit, str]] = {
    "traversal": (_names(["/../../somewhere/x", *SHIPPED_NAMES[1:]]), "class_names[0]"),
    "slash": (_names(["reef/a", *SHIPPED_NAMES[1:]]), "class_names[0]"),
    "control": (_names([*SHIPPED_NAMES[:3], "sph\x1b[31mere\n", *SHIPPED_NAMES[4:]]), "class_names[3]"),
    "integers": (_names(list(range(9))), "class_names[0]"),
    "too_few": (_names(SHIPPED_NAMES[:8]), "class_names"),
    "too_many": (_names([*SHIPPED_NAMES, "extra"]), "class_names"),
    "duplicate": (_names([*SHIPPED_NAMES[:8], "reef_a"]), "class_names"),
    "empty_name": (_names(["", *SHIPPED_NAMES[1:]]), "class_names[0]"),
    "n_points_0": (lambda d: d.__setitem__("n_points", 0), "n_points"),
    "n_points_neg": (lambda d: d.__setitem__("n_points", -5), "n_points"),
    "n_points_float": (lambda d: d.__setitem__("n_points", 256.0), "n_points"),
    "width_200": (_set("model_config", "width", 200.0), "model_config.width"),
    "width_nan": (_set("model_config", "width", math.nan), "model_config.width"),
    "width_zero": (_set("model_config", "width", 0.0), "model_config.width"),
    "threshold_neg": (_set("calibration", "clutter_threshold", -1.0), "calibration.clutter_threshold"),
    "threshold_nan": (_set("calibration", "clutter_threshold", math.nan), "calibration.clutter_threshold"),
    "threshold_str": (_set("calibration", "clutter_threshold", "0.5"), "calibration.clutter_threshold"),
    "threshold_above_1": (_set("calibration", "clutter_threshold", 1.5), "calibration.clutter_threshold"),
    "threshold_before_inf": (_set("calibration", "clutter_threshold_before", math.inf),
                             "calibration.clutter_threshold_before"),
    "scale_nan": (_set("synthesis", "scale_m", math.nan), "synthesis.scale_m"),
    "scale_neg": (_set("synthesis", "scale_m", -1.5), "synthesis.scale_m"),
    "z_ref": (_set("synthesis", "z_ref", "../x"), "synthesis.z_ref"),
    "metrics_nan": (lambda d: d["metrics"]["history"][2].__setitem__("val_loss", math.nan),
                    "metrics.history[2].val_loss"),
    "unknown_key": (lambda d: d.__setitem__("payload", 1), "payload"),
    "unknown_network_key": (_set("model_config", "heads", 3), "model_config.heads"),
    "missing": (lambda d: d.pop("n_points"), "n_points"),
    "too_deep": (lambda d: d["metrics"].__setitem__("a", _nested(40)), "metrics.a" + "[0]" * 32),
    "too_many_members": (lambda d: d.__setitem__("members", d["members"] * 17), "members"),
    "members_not_tables": (lambda d: d.__setitem__("members", ["x"]), "members[0]"),
    "weights_nan": (lambda d: d.__setitem__("state_dict", {**d["state_dict"], "classifier.bias":
                                                           torch.full((9,), math.nan)}), "state_dict.classifier.bias"),
}


def test_the_shipped_model_passes(shipped: dict[str, Any]) -> None:
    _doc, meta = read_checkpoint(DEFAULT_MODEL)
    assert meta.class_names == tuple(SHIPPED_NAMES) and meta.n_points == 256 and meta.network.width == 0.25
    ck = load_checkpoint(DEFAULT_MODEL)
    assert ck.class_names == tuple(SHIPPED_NAMES) and len(ck.members) == 3 and ck.calibration == shipped["calibration"]


@pytest.mark.parametrize("case", sorted(CASES))
def test_a_bad_field_is_one_line_naming_it(case: str, shipped: dict[str, Any], tmp_path: Path,
                                           monkeypatch: pytest.MonkeyPatch) -> None:
    edit, field = CASES[case]
    path = _bad(tmp_path, shipped, edit)

    def never_built(*args: object, **kwargs: object) -> None:
        raise AssertionError("a network was built from an unchecked checkpoint")

    monkeypatch.setattr("classify.checkpoint.PointNet", never_built)
    with pytest.raises(CheckpointError) as info:
        load_checkpoint(path)
    msg = str(info.value)
    assert f"checkpoint field {field!r}" in msg and "allowed: " in msg, msg
    assert "\n" not in msg and msg.isprintable() and str(path) in msg


def test_width_200_fails_fast_without_building(shipped: dict[str, Any], tmp_path: Path,
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    """Today a width of 200 builds the network first (over 6 GiB); checked, it never reaches the constructor."""
    path = _bad(tmp_path, shipped, _set("model_config", "width", 200.0))
    built: list[object] = []
    import classify.pointnet

    real_init = classify.pointnet.PointNet.__init__
    monkeypatch.setattr(classify.pointnet.PointNet, "__init__",
                        lambda self, cfg: (built.append(cfg), real_init(self, cfg))[1])  # type: ignore[func-returns-value]
    t0 = time.perf_counter()
    with pytest.raises(CheckpointError, match=rf"'model_config.width' = 200.0: .*\(allowed: a number in \(0, "
                                              rf"{MAX_WIDTH:g}\]\)"):
        Classifier.load(path, device=torch.device("cpu"))
    assert time.perf_counter() - t0 < 2.0 and built == []


def test_thresholds_at_the_ends_and_old_checkpoints_load(shipped: dict[str, Any], tmp_path: Path) -> None:
    for t in (0.0, 1.0):
        ck = load_checkpoint(_bad(tmp_path, shipped, _set("calibration", "clutter_threshold", t), f"t{t}.pt"))
        assert ck.calibration["clutter_threshold"] == t
    old = _bad(tmp_path, shipped, lambda d: [d.pop(k) for k in ("calibration", "metrics", "train", "members")],
               "old.pt")
    clf = Classifier.load(old, device=torch.device("cpu"))
    assert clf.clutter_threshold == 0.5 and clf.checkpoint.members == []


def test_save_refuses_what_load_would_refuse(shipped: dict[str, Any], tmp_path: Path) -> None:
    ck = load_checkpoint(DEFAULT_MODEL)
    with pytest.raises(CheckpointError, match="class_names"):
        save_checkpoint(tmp_path / "x.pt", ck.model, ("../x", *SHIPPED_NAMES[1:]), 256)
    assert not (tmp_path / "x.pt").exists()


class _Payload:
    def __reduce__(self) -> tuple[Callable[..., Any], tuple[str]]:
        return (os.system, ("touch /tmp/auvlink-t34-pwned",))


def test_loading_runs_no_pickled_code(shipped: dict[str, Any], tmp_path: Path) -> None:
    marker = Path("/tmp/auvlink-t34-pwned")
    marker.unlink(missing_ok=True)
    path = _bad(tmp_path, shipped, lambda d: d["metrics"].__setitem__("x", _Payload()))
    with pytest.raises(CheckpointError, match="not a readable checkpoint"):
        load_checkpoint(path)
    assert not marker.exists()


def _one_error_line(err: str, *needles: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("auvlink: error: ") and "Traceback" not in err, err
    for needle in needles:
        assert needle in lines[0], lines[0]
    return lines[0]


def test_cli_eval_names_the_bad_field(shipped: dict[str, Any], tmp_path: Path,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    bad = _bad(tmp_path, shipped, CASES["traversal"][0])
    assert main(["eval", "--model", str(bad), "--out", str(tmp_path / "ev")]) == 1
    _one_error_line(capsys.readouterr().err, "class_names[0]", "plain identifier")
    assert not (tmp_path / "ev" / "eval.json").exists()
    bad = _bad(tmp_path, shipped, CASES["scale_nan"][0], "scale.pt")  # refused before a survey is simulated
    assert main(["eval", "--surveys", "1", "--small", "--model", str(bad), "--out", str(tmp_path / "sv")]) == 1
    _one_error_line(capsys.readouterr().err, "synthesis.scale_m")
    assert not (tmp_path / "sv" / "surveys").exists()


@pytest.mark.slow
def test_cli_replay_and_batch_name_the_bad_field(small_mission_log: Path, shipped: dict[str, Any], tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    """``replay --model`` and ``batch --model`` with hostile class names and a huge width: one line each, no
    output folder written, nothing outside it."""
    for case in ("traversal", "width_200", "threshold_nan"):
        bad = _bad(tmp_path, shipped, CASES[case][0], f"{case}.pt")
        field = CASES[case][1]
        out = tmp_path / f"replay-{case}"
        assert main(["replay", str(small_mission_log), "--model", str(bad), "--out", str(out), "--quiet"]) == 1
        _one_error_line(capsys.readouterr().err, field)
        assert not (out / "detections.jsonl").exists()
        out = tmp_path / f"batch-{case}"
        assert main(["batch", str(small_mission_log), "--model", str(bad), "--out", str(out), "--quiet"]) == 1
        _one_error_line(capsys.readouterr().err, field)
        assert not (out / "batch.json").exists()
    assert not (tmp_path.parent / "somewhere").exists() and not Path("/somewhere").exists()
