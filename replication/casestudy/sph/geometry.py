"""Geometry of an SPH scene: the closed solid under a height field, its mirror image, the jet.

SPlisHSPlasH samples a static body's boundary from a closed triangle mesh, so the height
field becomes a solid: the surface on top, vertical walls along its boundary and a flat
bottom (the top's triangulation again, reversed) ``depth`` below its lowest point. The jet
is a column of fluid particles on a cubic lattice, centred on the jet axis and symmetric
about it (no particle on the axis), so a symmetric surface feels no lateral force.
"""

from __future__ import annotations

import numpy as np

__all__ = ["closed_solid", "jet_column", "mirror_about_y", "obj_text", "pda_text", "signed_volume"]


def mirror_about_y(points: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The surface and its mirror image in the plane y = 0, joined along it.

    Vertices on y = 0 are shared (the two halves become one mesh); mirrored triangles are
    reversed so that all stay counter-clockwise in the x-y projection.

    Notes
    -----
    Paper section 6 models half the domain with a symmetry plane; SPlisHSPlasH has none, so
    the half surface is mirrored and the whole jet simulated.
    """
    on_plane = points[:, 1] == 0.0
    index = np.arange(points.shape[0])
    mirrored = np.flatnonzero(~on_plane)
    index[mirrored] = points.shape[0] + np.arange(mirrored.size)
    image = points[mirrored] * [1.0, -1.0, 1.0]
    both = np.vstack([points, image])
    return both, np.vstack([triangles, index[triangles][:, ::-1]])


def closed_solid(points: np.ndarray, triangles: np.ndarray, depth: float) -> tuple[np.ndarray, np.ndarray]:
    """A closed, outward-oriented solid whose top is the height field (metres).

    Parameters
    ----------
    points : ndarray, shape (n, 3)
    triangles : ndarray of int, shape (m, 3)
        Counter-clockwise in the x-y projection (normals pointing up), conforming.
    depth : float
        How far the flat bottom lies below the lowest vertex.

    Returns
    -------
    points, triangles
        The top vertices followed by one bottom vertex under each; the top triangles, the
        bottom (reversed) and two triangles per boundary edge for the walls.
    """
    n = points.shape[0]
    bottom = points.copy()
    bottom[:, 2] = points[:, 2].min() - depth
    edges = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    inner = {(int(a), int(b)) for a, b in edges}
    boundary = np.array([(a, b) for a, b in inner if (b, a) not in inner], dtype=np.int64).reshape(-1, 2)
    boundary = boundary[np.lexsort((boundary[:, 1], boundary[:, 0]))]  # a deterministic order
    a, b = boundary[:, 0], boundary[:, 1]
    walls = np.concatenate([np.column_stack([a, b + n, b]), np.column_stack([a, a + n, b + n])])
    tris = np.vstack([triangles, triangles[:, ::-1] + n, walls])
    return np.vstack([points, bottom]), tris.astype(np.int64)


def signed_volume(points: np.ndarray, triangles: np.ndarray) -> float:
    """Volume enclosed by a closed mesh (positive when its normals point outwards)."""
    a, b, c = (points[triangles[:, k]] for k in range(3))
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def jet_column(
    center: tuple[float, float], radius: float, bottom: float, length: float, spacing: float
) -> tuple[np.ndarray, int]:
    """Particle positions of a vertical water column and its number of layers.

    Particles sit at the centres of the cells of a cubic lattice of step ``spacing`` whose
    cell corners include the jet axis; a cell belongs to the column when its centre lies
    within ``radius`` of the axis. The layers run upwards from ``bottom + spacing / 2``.
    """
    half = int(np.ceil(radius / spacing))
    offsets = (np.arange(-half, half) + 0.5) * spacing
    gx, gy = np.meshgrid(offsets, offsets, indexing="ij")
    keep = gx**2 + gy**2 <= radius**2
    xy = np.column_stack([gx[keep], gy[keep]]) + np.asarray(center, dtype=np.float64)
    layers = max(1, int(round(length / spacing)))
    z = bottom + spacing * (np.arange(layers) + 0.5)
    positions = np.column_stack([np.tile(xy, (layers, 1)), np.repeat(z, xy.shape[0])])
    return positions, layers


def obj_text(points: np.ndarray, triangles: np.ndarray) -> str:
    """A Wavefront OBJ mesh (vertices with shortest round-trip decimals, 1-based faces)."""
    lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in points.tolist()]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in triangles.tolist()]
    return "\n".join(lines) + "\n"


def pda_text(positions: np.ndarray) -> str:
    """Particle positions as partio's ASCII format (``.pda``), which SPlisHSPlasH reads."""
    header = [
        "ATTRIBUTES",
        "position",
        "TYPES",
        "V",
        f"NUMBER_OF_PARTICLES: {positions.shape[0]}",
        "BEGIN DATA",
    ]
    body = [f"{x!r} {y!r} {z!r}" for x, y, z in positions.astype(np.float32).astype(np.float64).tolist()]
    return "\n".join(header + body) + "\n"
