"""Domain randomization of the training synthesis over the acoustic space (classify.training.scan_acoustics)."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import open3d as o3d
import pytest

from auvlink.errors import AuvlinkError
from classify.training.config import load_train_settings
from classify.training.scan_acoustics import (
    ViewAcoustics,
    beam_leak,
    draw_acoustics,
    effective_edge,
    pattern_gain,
    ray_elevations,
    ray_weights,
)
from classify.training.scan_synth import energy_first_return, scan_points
from classify.training.synthesis import MeshSynthesizer, SynthesisSettings

S = math.radians(14.0)
H = 0.6  # box height
BASE = SynthesisSettings(mode="scan", detect="energy", altitude_m=(4.5, 4.5), lateral_m=(0.0, 0.0),
                         min_height_m=(0.1, 0.1), range_sigma_m=0.0, energy_threshold=(0.001, 0.001), min_run=2,
                         run_span_m=0.25, rays_per_beam=32, n_points=256)


def _box() -> MeshSynthesizer:
    m = o3d.geometry.TriangleMesh.create_box(1.2, 0.8, H)
    v = np.asarray(m.vertices) - [0.6, 0.4, H]  # NED: resting on z = 0, top at z = -H
    return MeshSynthesizer(v, np.asarray(m.triangles))


@pytest.mark.parametrize("shape", ["gaussian", "sinc2"])
def test_pattern_minus_3_db_at_nominal_edge_and_energy_beyond(shape: str) -> None:
    g = pattern_gain(shape, S, np.array([0.0, S / 2, 0.7 * S, 1.5 * S]), 3.0)
    assert g[0] == pytest.approx(1.0)
    assert 10 * math.log10(g[1]) == pytest.approx(-3.0, abs=0.02)
    assert 0.0 < g[2] < g[1]  # energy beyond the nominal edge
    assert g[3] == 0.0  # the end of the sampled extent (+-1.5 widths)
    assert pattern_gain("uniform", S, np.array([0.49 * S, 0.51 * S]), 1.0).tolist() == [1.0, 0.0]


def test_effective_edge_gaussian() -> None:
    # two-way gaussian, -3 dB at 7 deg: -20 dB at 7 sqrt(20 / 3.01) = 18.0 deg (extent +-28 deg: no taper there)
    assert math.degrees(effective_edge("gaussian", S, 4.0, -20.0)) == pytest.approx(18.05, abs=0.1)
    assert effective_edge("gaussian", S, 3.0, -20.0) < effective_edge("gaussian", S, 4.0, -20.0)  # the taper
    assert effective_edge("gaussian", S, 3.0, -10.0) < effective_edge("gaussian", S, 3.0, -20.0)
    assert effective_edge("uniform", S, 1.0, -20.0) == S / 2
    assert effective_edge("gaussian", S, 1.0, -20.0) == S / 2  # nothing sampled beyond the edge


def test_beam_leak_symmetric_main_lobe_and_sidelobes() -> None:
    leak = np.array(beam_leak(1.0, -25.0))
    assert len(leak) == 7 and leak[3] == 1.0
    np.testing.assert_allclose(leak, leak[::-1])
    assert 10 * math.log10(leak[4]) == pytest.approx(-12.04, abs=0.01)  # gaussian main lobe one beam off
    assert 10 * math.log10(leak[5]) == pytest.approx(-25.0, abs=0.01)  # the sidelobe level two beams off
    assert leak[6] == pytest.approx(leak[5] * 4 / 9)  # 1 / k^2


def test_ray_weights_sum_and_extent() -> None:
    ideal = ViewAcoustics(edge_rad=S / 2)
    el = ray_elevations(ideal, S, 32)
    assert len(el) == 32 and el[-1] == pytest.approx(S / 2)
    assert ray_weights(ideal, S, el).sum() == pytest.approx(1.0)
    wide = ViewAcoustics(pattern="gaussian", extent=3.0, edge_rad=math.radians(18.0))
    el = ray_elevations(wide, S, 32)
    assert el[-1] == pytest.approx(1.5 * S) and len(el) == 64  # as dense as 32 rays over the nominal 14 deg
    w = ray_weights(wide, S, el)
    assert w[el > S / 2].sum() > 0.1 * w.sum()  # a real share of the energy beyond the nominal edge


def test_draw_off_is_ideal_and_seeded() -> None:
    rng = np.random.default_rng(0)
    assert draw_acoustics(BASE, S, rng).ideal and rng.random() == np.random.default_rng(0).random()
    dr = replace(BASE, dr_prob=1.0)
    a, b = draw_acoustics(dr, S, np.random.default_rng(3)), draw_acoustics(dr, S, np.random.default_rng(3))
    assert a == b
    draws = [draw_acoustics(dr, S, np.random.default_rng(i)) for i in range(200)]
    assert {d.pattern for d in draws} == {"uniform", "gaussian", "sinc2"}
    assert {d.pulse_bins for d in draws} == {1, 2, 3, 4}
    edges = np.degrees([d.edge_rad for d in draws if d.pattern == "gaussian"])
    assert edges.min() < 7.5 and edges.max() > 15.0  # the nominal edge and effective edges well beyond it
    db = 10 * np.log10([d.threshold_factor for d in draws])
    assert db.min() >= -6.0 and db.max() <= 6.0 and db.max() - db.min() > 10.0


def test_pulse_spreads_and_leak_reaches_neighbours() -> None:
    t = np.full((1, 4, 3), 5.001)
    cos = np.ones((1, 4, 3))
    hit = np.zeros((1, 4, 3), dtype=bool)
    hit[0, :, 1] = True  # the middle beam: 4 rays in one bin, energy (6/5)^2
    e = 1.44
    assert np.isfinite(energy_first_return(t, cos, hit, e * 0.9, 0.02, 1)[0, 1])
    assert np.isinf(energy_first_return(t, cos, hit, e * 0.9, 0.02, 1, pulse_bins=2)[0, 1])  # halved per bin
    assert np.isfinite(energy_first_return(t, cos, hit, e * 0.4, 0.02, 2, pulse_bins=2)[0, 1])  # 2 bins now
    plain = energy_first_return(t, cos, hit, e * 0.01, 0.02, 1)
    assert np.isinf(plain[0, 0]) and np.isinf(plain[0, 2])
    leaked = energy_first_return(t, cos, hit, e * 0.01, 0.02, 1, leak=beam_leak(1.0, -25.0))
    assert np.isfinite(leaked).all() and leaked[0, 0] == leaked[0, 1] == leaked[0, 2]


def test_energy_beyond_the_edge_lifts_points_above_the_top() -> None:
    """Recon placing returns on the nominal edge while the beam reaches steeper: the first return comes from rays
    below the edge, at shorter range, and lands above the object's top (as recon makes of DIDSON frames)."""
    synth = _box()
    tilt = math.radians(30.0)
    ideal = scan_points(synth.scene, synth.vertices, 0.0, tilt, BASE, np.random.default_rng(1))
    assert -ideal[:, 2].min() == pytest.approx(H, abs=0.03)
    wide = replace(BASE, dr_prob=1.0, dr_pattern_weights=(0.0, 1.0, 0.0), dr_extent=(3.0, 3.0),
                   dr_nominal_edge_prob=1.0, dr_threshold_db=(0.0, 0.0), dr_tvg_db_per_m=(0.0, 0.0),
                   dr_seabed_bias_m=(0.0, 0.0), dr_speckle_looks=0.0)
    lifted = scan_points(synth.scene, synth.vertices, 0.0, tilt, wide, np.random.default_rng(1))
    assert -lifted[:, 2].min() > H + 0.2
    # placed on an effective edge drawn at -20 dB (~18 deg), with recon's seabed fitted 0.3 m deeper
    edge = replace(wide, dr_nominal_edge_prob=0.0, dr_edge_level_db=(-20.0, -20.0), dr_edge_error_deg=0.0,
                   dr_seabed_bias_m=(0.3, 0.3))
    placed = scan_points(synth.scene, synth.vertices, 0.0, tilt, edge, np.random.default_rng(1))
    assert len(placed) > 50
    assert -placed[:, 2].max() >= 0.1 - 1e-9  # recon's seabed removal, above its own seabed
    assert np.median(-placed[:, 2]) < np.median(-lifted[:, 2]) + 0.3  # the steeper edge places lower


def test_randomization_bounds_checked(tmp_path: Path) -> None:
    bad = tmp_path / "t.toml"
    bad.write_text("[synthesis]\ndr_prob = 1.5\n")
    with pytest.raises(AuvlinkError, match="dr_prob"):
        load_train_settings(bad)


def test_eval_recon_takes_one_profile(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from auvlink.cli import main

    assert main(["eval", "--recon", "--acoustics", "random", "--out", str(tmp_path / "e")]) != 0
    assert "--acoustics random" in capsys.readouterr().err
    assert not (tmp_path / "e").exists()


def test_standard_passes_under_a_profile() -> None:
    from auvlink.evaluation.recon_eval import standard_passes

    assert standard_passes().acoustics == "ideal"
    quick = standard_passes(True, "didson")
    assert quick.acoustics == "didson" and quick == replace(standard_passes(True), acoustics="didson")
