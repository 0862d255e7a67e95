"""The example configuration files in examples/ load and name real formats."""

from __future__ import annotations

from pathlib import Path

import pytest

from auvlink.config import load_config

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.mark.parametrize("name", ["virtual_ports.toml", "hardware.toml"])
def test_example_config_loads(name: str) -> None:
    cfg = load_config(EXAMPLES / name)
    names = [d.name for d in cfg.devices]
    assert names == ["dvl", "gyro", "pressure", "can", "sonar", "gnss"]
    assert {d.format for d in cfg.devices} == {"pd0", "dsp1760", "keller", "can", "didson", "nmea"}
    assert cfg.site is not None and (cfg.site.latitude, cfg.site.longitude) == (36.0412, 129.3915)
    assert cfg.sonar is not None and cfg.sonar.tilt_deg == 30.0
