"""recon/__init__.py's module map names every module of the package, and no module that is gone."""

from __future__ import annotations

import re
from pathlib import Path

import recon


def test_the_module_map_lists_every_recon_module() -> None:
    root = Path(recon.__file__).parent
    modules = {p.stem for p in root.glob("*.py") if p.stem != "__init__"}
    named = set(re.findall(r":mod:`recon\.(\w+)`", recon.__doc__ or ""))
    assert modules - named == set(), f"not in the module map: {sorted(modules - named)}"
    assert named - modules == set(), f"in the module map but gone: {sorted(named - modules)}"
