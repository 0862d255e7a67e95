"""Frames: attitude convention, mountings, RDI ship/earth/instrument -> FRD/NED, PD0 sign."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from auvlink.errors import AuvlinkError
from recon.errors import GeometryError
from recon.frames import (
    Mounting,
    attitude,
    bottom_track_to_vehicle,
    check_attitude,
    euler,
    rdi_earth_to_ned,
    rdi_instrument_mounting,
    rdi_ship_to_body,
    to_body,
    to_ned,
)

D = np.deg2rad


def test_attitude_convention() -> None:
    # heading 90 deg: forward points east
    assert np.allclose(attitude(D(90), 0, 0).apply([1, 0, 0]), [0, 1, 0])
    # nose up 10 deg: forward has an upward (negative down) component
    f = attitude(0, D(10), 0).apply([1, 0, 0])
    assert np.allclose(f, [np.cos(D(10)), 0, -np.sin(D(10))])
    # roll starboard down: starboard axis points down
    s = attitude(0, 0, D(20)).apply([0, 1, 0])
    assert np.allclose(s, [0, np.cos(D(20)), np.sin(D(20))])
    # R_WB = Rz Ry Rx
    y, p, r = D(35), D(-5), D(12)
    m = Rotation.from_euler("z", y) * Rotation.from_euler("y", p) * Rotation.from_euler("x", r)
    assert np.allclose(attitude(y, p, r).as_matrix(), m.as_matrix())
    yy, pp, rr = euler(attitude([y, D(190)], [p, 0], [r, 0]))
    assert np.allclose([yy[0], pp[0], rr[0]], [y, p, r])
    assert np.isclose(yy[1], D(-170))


def test_sonar_mounting_tilt_looks_down() -> None:
    t = D(30)
    m = Mounting.sonar(t, lever_arm=(1.0, 0.0, 0.2))
    assert np.allclose(m.rotation.apply([1, 0, 0]), [np.cos(t), 0, np.sin(t)])
    assert np.allclose(m.lever, [1.0, 0.0, 0.2])
    with pytest.raises(GeometryError):
        Mounting(lever_arm=(0.0, float("nan"), 0.0))


def test_rdi_ship_and_earth() -> None:
    ship = np.array([[0.1, 1.0, -0.05]])  # starboard, forward, up
    assert np.allclose(rdi_ship_to_body(ship), [[1.0, 0.1, 0.05]])
    earth = np.array([0.3, 0.4, 0.1])  # east, north, up
    assert np.allclose(rdi_earth_to_ned(earth), [0.4, 0.3, -0.1])
    assert np.allclose(to_ned(earth, "earth"), [0.4, 0.3, -0.1])


def test_rdi_instrument_mounting() -> None:
    v = np.array([0.2, 1.5, -0.1])  # instrument X, Y, Z
    # default: down-looking, beam 3 forward: instrument axes are the ship axes
    assert np.allclose(to_body(v, "instrument"), rdi_ship_to_body(v))
    up = rdi_instrument_mounting(up_looking=True)
    assert np.allclose(to_body(v, "instrument", up), [1.5, -0.2, -0.1])
    ea = rdi_instrument_mounting(heading_misalignment=D(90))  # instrument forward points starboard
    assert np.allclose(to_body([0.0, 1.0, 0.0], "instrument", ea), [0.0, 1.0, 0.0])
    assert np.allclose(to_body([1.0, 0.0, 0.0], "instrument", ea), [-1.0, 0.0, 0.0])


def test_body_frames_to_ned_with_attitude() -> None:
    rot = attitude(D(90), 0, 0)
    ship = np.array([0.0, 2.0, 0.0])  # 2 m/s forward
    assert np.allclose(to_ned(ship, "ship", rot), [0, 2, 0])
    assert np.allclose(to_ned([1.0, 0, 0], "body", rot), [0, 1, 0])
    with pytest.raises(GeometryError):
        to_ned(ship, "ship")


def test_bottom_track_sign() -> None:
    # PD0 bottom track: the bottom moves backwards relative to an instrument moving forwards
    bt_ship = np.array([0.0, -1.2, 0.0])
    assert np.allclose(rdi_ship_to_body(bottom_track_to_vehicle(bt_ship)), [1.2, 0, 0])


def test_check_attitude_rejects_gimbal_lock() -> None:
    check_attitude(attitude([0, 1, 2], [D(60), D(-60), 0], [0, D(40), D(170)]))
    for pitch in (D(89), D(-88.5), D(90)):
        with pytest.raises(GeometryError, match="pitch"):
            check_attitude(attitude(0.3, pitch, 0.0))
    assert issubclass(GeometryError, AuvlinkError)
