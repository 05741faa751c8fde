"""Small meshes with known fold descriptors, and plain Mitsuba scenes of them, for the fold tests."""

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


def mesh_shape(vertices, faces, *, normals=None, bsdf=None, name: str = "mesh"):
    """A Mitsuba triangle mesh from arrays (flat-shaded without normals); ``bsdf`` a dict or object."""
    import drjit as dr

    from weavecap.backend import mitsuba

    mi = mitsuba()
    v = np.ascontiguousarray(vertices, np.float32)
    f = np.ascontiguousarray(faces, np.uint32)
    props = mi.Properties()
    if bsdf is not None:
        props["bsdf"] = mi.load_dict(bsdf) if isinstance(bsdf, dict) else bsdf
    mesh = mi.Mesh(name, len(v), len(f), props=props, has_vertex_normals=normals is not None)
    params = mi.traverse(mesh)
    params["vertex_positions"] = dr.ravel(mi.Point3f(*v.T))
    params["faces"] = dr.ravel(mi.Vector3u(*f.T))
    if normals is not None:
        params["vertex_normals"] = dr.ravel(mi.Normal3f(*np.ascontiguousarray(normals, np.float32).T))
    params.update()
    return mesh


def diffuse(albedo) -> dict:
    """A two-sided Lambertian BSDF dictionary of an RGB (or grey) albedo."""
    rgb = np.broadcast_to(np.asarray(albedo, float), (3,)).tolist()
    return {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": rgb}}}


def directional(direction, irradiance=1.0) -> dict:
    """A directional emitter dictionary: light travelling along ``direction``, RGB irradiance."""
    d = np.asarray(direction, float)
    rgb = np.broadcast_to(np.asarray(irradiance, float), (3,)).tolist()
    return {"type": "directional", "direction": (d / np.linalg.norm(d)).tolist(),
            "irradiance": {"type": "rgb", "value": rgb}}
