"""Peer for the PD0 benchmark: dolfyn 1.3.0 in its own small venv (it needs numpy < 2 and, for
``scipy.integrate.cumtrapz``, scipy < 1.14).

``ensure_venv()`` builds ``~/.cache/auvlink/dolfyn-1.3.0`` once (pip from the package registry);
``time_dolfyn(path, repeat)`` runs ``dolfyn.read`` there in a subprocess and returns seconds per read.
Nothing here raises: a failure returns ``(None, reason)`` so the benchmark reports it as skipped.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

VERSION = "1.3.0"
VENV = Path(os.environ.get("AUVLINK_CACHE", Path.home() / ".cache" / "auvlink")) / f"dolfyn-{VERSION}"

#: dolfyn 1.3.0 predates numpy 2, scipy 1.14 (cumtrapz removed) and newer xarray
PINS = ("numpy<2", "scipy<1.14", "xarray<2024.7")

_TIMER = r"""
import json, sys, time, warnings
warnings.filterwarnings("ignore")
import dolfyn
path, repeat = sys.argv[1], int(sys.argv[2])
best = float("inf"); n = 0
for _ in range(repeat):
    t0 = time.perf_counter()
    ds = dolfyn.read(path, nens=None)
    best = min(best, time.perf_counter() - t0)
    n = int(ds.sizes["time"])
print(json.dumps({"seconds": best, "ensembles": n, "version": dolfyn.__version__}))
"""


def _python() -> Path:
    return VENV / "bin" / "python"


def ensure_venv(build: bool = True) -> tuple[bool, str]:
    """Create the dolfyn venv if it is missing (unless ``build`` is False). Returns (ok, reason)."""
    if _python().exists():
        ok = subprocess.run([str(_python()), "-c", "import dolfyn"], capture_output=True).returncode == 0
        if ok:
            return True, "ok"
    if not build:
        return False, f"the dolfyn {VERSION} venv ({VENV}) is not built; `auvlink bench decode` builds it"
    try:
        subprocess.run([sys.executable, "-m", "venv", str(VENV)], check=True, capture_output=True)
        subprocess.run(
            [str(_python()), "-m", "pip", "install", "-q", f"dolfyn=={VERSION}", *PINS],
            check=True, capture_output=True, timeout=900,
        )
    except (subprocess.SubprocessError, OSError) as exc:
        err = getattr(exc, "stderr", b"") or b""
        tail = err.decode(errors="replace").strip().splitlines()[-1:] if err else [str(exc)]
        return False, f"could not build the dolfyn {VERSION} venv: {' '.join(tail)}"
    return True, "ok"


def time_dolfyn(path: Path, repeat: int = 3, build: bool = True) -> tuple[dict[str, float] | None, str]:
    ok, reason = ensure_venv(build)
    if not ok:
        return None, reason
    proc = subprocess.run(
        [str(_python()), "-c", _TIMER, str(path), str(repeat)], capture_output=True, text=True, timeout=900
    )
    if proc.returncode != 0:
        return None, f"dolfyn failed: {proc.stderr.strip().splitlines()[-1:]}"
    return json.loads(proc.stdout.strip().splitlines()[-1]), "ok"
