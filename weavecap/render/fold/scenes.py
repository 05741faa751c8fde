"""Mitsuba shapes from arrays, for the fold renderer's training and tests.

The render command builds its scenes itself (:mod:`weavecap.render`); the fold renderer also
needs plain scenes of its own — the procedural fold suite under a directional light, rendered
by LocalPT for training data — made from numpy arrays without files.
"""

from __future__ import annotations

import numpy as np

from ...backend import mitsuba

mi = mitsuba()
import drjit as dr  # noqa: E402  (after the backend chose libLLVM)


def mesh_shape(vertices, faces, *, normals=None, bsdf=None, name: str = "mesh") -> "mi.Mesh":
    """A Mitsuba triangle mesh from (V, 3) vertices, (F, 3) faces and optional (V, 3) normals.

    ``bsdf`` is a Mitsuba BSDF object or a ``load_dict`` dictionary (default: Mitsuba's
    diffuse, albedo 0.5). Without normals the mesh is flat-shaded.
    """
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
        n = np.ascontiguousarray(normals, np.float32)
        params["vertex_normals"] = dr.ravel(mi.Normal3f(*n.T))
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
