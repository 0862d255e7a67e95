"""Draw docs/img/acoustic_profiles.png: one frame of the shipped demo scene under every acoustic profile.

The frame (survey time 87.5 s, reef_a ahead) is rendered under ``ideal`` (today's model), each
sonar profile of :mod:`auvlink.sim.acoustics` and a harsh draw (:data:`HARSH`), with the same pose and
the same frame generator; ``--print`` also prints each panel's grey-level statistics.

Run: ``python scripts/acoustic_profiles_figure.py [--out docs/img/acoustic_profiles.png] [--print]``.
"""

from __future__ import annotations

import argparse
import math
from dataclasses import replace
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from auvlink.sim.acoustics import PROFILES, AcousticsTable
from auvlink.sim.scene import load_default_scene
from auvlink.sim.sonar_render import SonarRenderer, frame_rng
from auvlink.sim.trajectory import LawnmowerTrajectory

#: survey time of the frame (s): reef_a fills the fan
FRAME_T = 87.5
#: a harsh draw from the acoustic space of issue 36: sinc^2 pattern, -20 dB sidelobes, a 3-bin
#: pulse, +6 dB gain, a TVG error, K-distributed speckle and an interference band in this frame
HARSH = AcousticsTable(profile="didson", vertical_pattern="sinc2", sidelobe_db=-20.0, pulse_m=0.06,
                       gain_db=6.0, gain_jitter_db=0.0, tvg_error_db_per_m=-1.0, texture_shape=2.0,
                       interference_fraction=1.0, interference_db=-12.0)


def panels() -> list[tuple[str, np.ndarray]]:
    """(title, uint8 image [range bin, beam]) for ideal, each sonar profile and the harsh draw."""
    scene = load_default_scene()
    pose = LawnmowerTrajectory.from_scene(scene).true_pose(np.array([FRAME_T]))
    position, r_wb = pose.position[0], pose.rotation().as_matrix()[0]
    tables = [(name, AcousticsTable(profile=name)) for name in PROFILES]
    out = []
    for title, table in [*tables, ("harsh draw", HARSH)]:
        rd = SonarRenderer(replace(scene, acoustics=table))
        out.append((title, rd.image(rd.trace_matrix(position, r_wb), frame_rng(scene.seed, 0))))
    return out


def draw(out: Path, show_stats: bool) -> None:
    scene = load_default_scene()
    son = scene.sonar
    half = son.description.half_fov_deg  # the simulator's fan (the scene's sonar model, auvlink.sonar)
    items = panels()
    fig, axes = plt.subplots(1, len(items), figsize=(3.0 * len(items), 4.6), sharey=True)
    for ax, (title, img) in zip(axes, items, strict=True):
        ax.imshow(img, origin="lower", aspect="auto", cmap="gray", vmin=0, vmax=255,
                  extent=(-half, half, son.window_start, son.window_end))
        ax.set_title(title)
        ax.set_xlabel("azimuth (deg)")
        if show_stats:
            print(f"{title:10s} mean {img.mean():6.1f}  p5 {np.percentile(img, 5):5.0f}  "
                  f"p95 {np.percentile(img, 95):5.0f}  zeros {(img == 0).mean():.3f}")
    axes[0].set_ylabel("range (m)")
    edge = math.radians(son.tilt_deg + son.spread_deg / 2.0)
    fig.suptitle(f"demo scene, survey t = {FRAME_T} s: tilt {son.tilt_deg:g} deg, spread {son.spread_deg:g} deg, "
                 f"altitude {scene.survey.altitude:g} m (a hard beam edge sees the seabed from "
                 f"{scene.survey.altitude / math.sin(edge):.1f} m)")
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=90)
    print(out)


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parents[1] / "docs" / "img"
                    / "acoustic_profiles.png")
    ap.add_argument("--print", dest="show", action="store_true", help="print each panel's statistics")
    args = ap.parse_args()
    draw(args.out, args.show)
