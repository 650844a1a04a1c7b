"""Checks and canonical form for the printed parts' STL files.

- `canonical_stl`: OpenSCAD 2021.01 writes facets in an order that follows memory addresses;
  rotating each triangle to start at its smallest vertex (winding kept) and sorting the triangles
  makes the file depend on the geometry only.
- `manifold_problems`: a printable part is a closed, consistently wound 2-manifold with positive
  volume (trimesh), and manifold3d accepts it as a manifold.
- `overhangs`: the STL is in print orientation; any facet facing down more steeply than
  `max_deg` from vertical that is not lying on the bed needs support.
"""
from __future__ import annotations

import math
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

STL_DTYPE = np.dtype([("n", "<f4", (3,)), ("v", "<f4", (3, 3)), ("attr", "<u2")])


def _read_binary(path: Path) -> np.ndarray:
    data = path.read_bytes()
    if len(data) < 84:
        raise ValueError(f"{path}: not a binary STL (too short)")
    (n,) = struct.unpack_from("<I", data, 80)
    if len(data) != 84 + 50 * n:
        raise ValueError(f"{path}: not a binary STL ({len(data)} bytes for {n} facets)")
    return np.frombuffer(data, STL_DTYPE, count=n, offset=84)


def canonical_stl(src: Path, dst: Path, header: str) -> int:
    """Rewrites binary STL `src` to `dst` with sorted facets; returns the facet count."""
    tri = _read_binary(src).copy()
    v = tri["v"]
    # Start every triangle at its lexicographically smallest vertex (a rotation keeps winding).
    first = np.zeros(len(v), dtype=int)
    for k in (1, 2):
        a, b = v[np.arange(len(v)), first], v[:, k]
        less = (b[:, 0] < a[:, 0]) | ((b[:, 0] == a[:, 0]) & ((b[:, 1] < a[:, 1]) |
                                                              ((b[:, 1] == a[:, 1]) & (b[:, 2] < a[:, 2]))))
        first = np.where(less, k, first)
    idx = (first[:, None] + np.arange(3)[None, :]) % 3
    tri["v"] = v[np.arange(len(v))[:, None], idx]
    tri["attr"] = 0
    flat = tri["v"].reshape(len(tri), 9)
    tri = tri[np.lexsort(flat.T[::-1])]
    head = header.encode("ascii")[:80].ljust(80, b" ")
    dst.write_bytes(head + struct.pack("<I", len(tri)) + tri.tobytes())
    return len(tri)


def load(path: Path):
    import trimesh
    return trimesh.load(str(path), force="mesh", process=True)


def manifold_problems(path: Path) -> list[str]:
    import manifold3d
    m = load(path)
    problems = []
    if not m.is_watertight:
        problems.append("not watertight (open edges)")
    if not m.is_winding_consistent:
        problems.append("inconsistent winding")
    if m.volume <= 0:
        problems.append(f"volume {m.volume:.3f} mm^3 is not positive (inside out)")
    mesh = manifold3d.Mesh(vert_properties=np.asarray(m.vertices, dtype=np.float32),
                           tri_verts=np.asarray(m.faces, dtype=np.uint32))
    status = manifold3d.Manifold(mesh).status()
    if status != manifold3d.Error.NoError:
        problems.append(f"manifold3d rejects it: {status.name}")
    return problems


@dataclass
class Overhang:
    area: float                                  # mm^2 facing down too steeply, off the bed
    facets: int
    box: tuple[float, ...] | None                # where (x0, y0, z0, x1, y1, z1)


def overhangs(path: Path, max_deg: float = 45.0, tol_deg: float = 0.5, bed_tol: float = 1e-3) -> Overhang:
    m = load(path)
    n = m.face_normals
    limit = -math.cos(math.radians(max_deg + tol_deg))       # normal z below this: too steep
    tri = m.triangles
    zbed = m.bounds[0][2]
    on_bed = np.all(np.abs(tri[:, :, 2] - zbed) < bed_tol, axis=1)
    bad = (n[:, 2] < limit) & ~on_bed
    if not bad.any():
        return Overhang(0.0, 0, None)
    pts = tri[bad].reshape(-1, 3)
    return Overhang(float(m.area_faces[bad].sum()), int(bad.sum()),
                    tuple(round(float(x), 3) for x in (*pts.min(axis=0), *pts.max(axis=0))))


def volume(path: Path) -> float:
    return float(load(path).volume)
