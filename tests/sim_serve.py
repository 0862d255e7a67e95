"""The live fault tests' simulator in its own process: a scene served on a vehicle configuration's virtual ports
through the ``PortHook`` that ``MODULE:ATTRIBUTE`` names (a module on this folder's path; the attribute a hook,
or a callable that makes one), the port list printed as ``auvlink sim --live`` prints it.

    python tests/sim_serve.py CONFIG.toml SCENE.toml SPEED MODULE:ATTRIBUTE
"""

from __future__ import annotations

import importlib
import sys

from auvlink.config import load_config
from auvlink.sim.device_server import serve
from auvlink.sim.scene import load_scene


def main(argv: list[str]) -> int:
    config, scene, speed, hook_name = argv
    module, _, attribute = hook_name.partition(":")
    hook = getattr(importlib.import_module(module), attribute)
    serve(load_scene(scene), load_config(config), speed=float(speed), out=sys.stdout,
          hook=hook() if callable(hook) else hook)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
