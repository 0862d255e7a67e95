"""PLY output (the one module of :mod:`recon` that writes files): cloud.ply and per-object PLYs.

A small numpy writer of the Stanford PLY format (ascii or binary_little_endian 1.0): vertices with
``double`` x, y, z (world NED metres keep millimetres far from the origin, float would not),
optional ``uchar`` red, green, blue and optional per-point scalars (``uint`` for integer arrays such
as ``object_id``, ``double`` for the others such as ``time``). Open3D, MeshLab and CloudCompare read
these files. The frame is stated in a ``comment`` line (world NED unless the caller says otherwise).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from recon.cluster import DetectedObject
from recon.errors import ReconError

PlyFormat = Literal["binary", "ascii"]


NED_COMMENT = "auvlink recon, world frame NED (m)"


def write_ply(path: str | Path, points: ArrayLike, colors: ArrayLike | None = None,
              fmt: PlyFormat = "binary", scalars: Mapping[str, ArrayLike] | None = None,
              comment: str = NED_COMMENT) -> Path:
    """Write (N, 3) points (and (N, 3) uint8 colours, and (N,) ``scalars`` by property name) to
    ``path``; returns the path."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if not np.all(np.isfinite(p)):
        raise ReconError("PLY points must be finite")
    fields = [("x", "<f8"), ("y", "<f8"), ("z", "<f8")]
    c = None
    if colors is not None:
        c = np.asarray(colors, dtype=np.uint8).reshape(-1, 3)
        if c.shape[0] != p.shape[0]:
            raise ReconError(f"{c.shape[0]} colours for {p.shape[0]} points")
        fields += [("red", "u1"), ("green", "u1"), ("blue", "u1")]
    extra: dict[str, np.ndarray] = {}
    for name, values in (scalars or {}).items():
        v = np.asarray(values).reshape(-1)
        if v.shape[0] != p.shape[0]:
            raise ReconError(f"{v.shape[0]} values of {name!r} for {p.shape[0]} points")
        if not name.isidentifier():
            raise ReconError(f"PLY property name {name!r} is not a plain name")
        integer = np.issubdtype(v.dtype, np.integer)
        if integer and v.size and (v.min() < 0 or v.max() > 0xFFFFFFFF):
            raise ReconError(f"{name!r} does not fit a PLY uint")
        extra[name] = v.astype("<u4" if integer else "<f8")
        fields.append((name, "<u4" if integer else "<f8"))
    rec = np.empty(p.shape[0], dtype=fields)
    rec["x"], rec["y"], rec["z"] = p[:, 0], p[:, 1], p[:, 2]
    if c is not None:
        rec["red"], rec["green"], rec["blue"] = c[:, 0], c[:, 1], c[:, 2]
    for name, v in extra.items():
        rec[name] = v
    kind = "binary_little_endian" if fmt == "binary" else "ascii"
    header = ["ply", f"format {kind} 1.0", f"comment {comment}",
              f"element vertex {p.shape[0]}", "property double x", "property double y", "property double z"]
    if c is not None:
        header += ["property uchar red", "property uchar green", "property uchar blue"]
    header += [f"property {'uint' if v.dtype.kind == 'u' else 'double'} {name}" for name, v in extra.items()]
    header.append("end_header")
    out = Path(path)
    with out.open("wb") as fh:
        fh.write(("\n".join(header) + "\n").encode("ascii"))
        if fmt == "binary":
            fh.write(rec.tobytes())
        else:
            cols = [p[:, k] for k in range(3)] + ([c[:, k] for k in range(3)] if c is not None else [])
            fmts = ["%.6f"] * 3 + (["%d"] * 3 if c is not None else [])
            cols += list(extra.values())
            fmts += ["%d" if v.dtype.kind == "u" else "%.9f" for v in extra.values()]
            np.savetxt(fh, np.column_stack(cols), fmt=fmts)
    return out


def write_objects(out_dir: str | Path, objects: Sequence[DetectedObject], fmt: PlyFormat = "binary",
                  prefix: str = "object") -> dict[int, Path]:
    """One PLY per object (``<prefix>_<id>.ply``) in ``out_dir``; returns {id: path}."""
    d = Path(out_dir)
    d.mkdir(parents=True, exist_ok=True)
    return {o.id: write_ply(d / f"{prefix}_{o.id:03d}.ply", o.points, fmt=fmt) for o in objects}


def write_cloud(path: str | Path, objects: Sequence[DetectedObject], fmt: PlyFormat = "binary") -> Path:
    """cloud.ply: all object points, coloured per object (a fixed palette, by id)."""
    palette = np.array([[230, 25, 75], [60, 180, 75], [255, 225, 25], [0, 130, 200], [245, 130, 48],
                        [145, 30, 180], [70, 240, 240], [240, 50, 230], [210, 245, 60], [250, 190, 212]],
                       np.uint8)
    pts = [o.points for o in objects]
    cols = [np.repeat(palette[o.id % len(palette)][None], o.n_points, axis=0) for o in objects]
    if not pts:
        return write_ply(path, np.zeros((0, 3)), np.zeros((0, 3), np.uint8), fmt)
    return write_ply(path, np.concatenate(pts), np.concatenate(cols), fmt)
