"""Small meshes with known fold descriptors, made here for the fold tests (numpy only)."""

from __future__ import annotations

import numpy as np


def grid_faces(rows: int, cols: int) -> np.ndarray:
    """Two triangles per cell of a rows × cols vertex grid (row-major), counter-clockwise from +z."""
    i, j = np.meshgrid(np.arange(rows - 1), np.arange(cols - 1), indexing="ij")
    a = (i * cols + j).ravel()
    b, c, d = a + 1, a + cols, a + cols + 1
    return np.concatenate([np.stack([a, c, d], 1), np.stack([a, d, b], 1)]).astype(np.int64)


def heightfield(fn, size: float = 2.0, n: int = 81) -> tuple[np.ndarray, np.ndarray]:
    """z = fn(x, y) over [-size/2, size/2]², normals towards +z."""
    x, y = np.meshgrid(np.linspace(-size / 2, size / 2, n), np.linspace(-size / 2, size / 2, n), indexing="ij")
    v = np.stack([x, y, fn(x, y)], -1).reshape(-1, 3)
    return v, grid_faces(n, n)


def sphere(radius: float = 1.0, n: int = 48) -> tuple[np.ndarray, np.ndarray]:
    """A UV sphere with outward normals (poles shared)."""
    theta = np.linspace(0, np.pi, n + 1)[1:-1]
    phi = np.linspace(0, 2 * np.pi, 2 * n, endpoint=False)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    ring = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1).reshape(-1, 3)
    v = radius * np.concatenate([[[0, 0, 1]], ring, [[0, 0, -1]]])
    m, rows = 2 * n, n - 1
    faces = []
    for j in range(m):
        faces.append([0, 1 + j, 1 + (j + 1) % m])
        faces.append([len(v) - 1, 1 + (rows - 1) * m + (j + 1) % m, 1 + (rows - 1) * m + j])
    for i in range(rows - 1):
        for j in range(m):
            a, b = 1 + i * m + j, 1 + i * m + (j + 1) % m
            c, d = a + m, b + m
            faces += [[a, c, d], [a, d, b]]
    return v, np.array(faces, np.int64)


def cylinder(radius: float = 1.0, length: float = 4.0, n: int = 96, rows: int = 97) -> tuple[np.ndarray, np.ndarray]:
    """An open cylinder along y with outward normals."""
    phi = np.linspace(0, 2 * np.pi, n, endpoint=False)
    y = np.linspace(-length / 2, length / 2, rows)
    yy, pp = np.meshgrid(y, phi, indexing="ij")
    v = np.stack([radius * np.cos(pp), yy, radius * np.sin(pp)], -1).reshape(-1, 3)
    faces = []
    for i in range(rows - 1):
        for j in range(n):
            a, b = i * n + j, i * n + (j + 1) % n
            c, d = a + n, b + n
            faces += [[a, d, b], [a, c, d]]
    return v, np.array(faces, np.int64)
