"""A garment mesh for rendering: read (OBJ, PLY), checked, cleaned, measured, with UVs in metres.

:func:`load_mesh` reads the file with trimesh (one object, every object of a multi-object
OBJ, or the one ``object_name`` names), refuses what cannot be rendered with an
:class:`~weavecap.errors.InputError` naming the file and the problem (no faces, NaN/Inf
vertices, face indices out of range, more than MAX_FACES faces, not a mesh, smaller than
0.1 mm or larger than 10 km), and repairs what can be (n-gons triangulated on reading,
degenerate faces dropped, duplicate vertices merged, a missing ``.mtl`` ignored). It returns a
:class:`RenderMesh` whose texture coordinates are the fabric's coordinates in metres:

- without UVs in the file (or with UVs on too few faces, NaN ones, or a layout without area),
  xatlas makes them and the notes say why;
- whatever the layout's scale, each UV island is solved for the coordinates that are, face by
  face, as close as possible to a rotation of the 3D surface — the rotation read from the
  layout (its grain direction kept), the stretch taken out — by one least-squares solve per
  island (the global step of as-rigid-as-possible parametrization with the layout's rotations:
  Liu et al. 2008). A garment's panels are nearly developable, so the weave then keeps its
  physical size everywhere; :attr:`RenderMesh.stretch` says how much was left (measured).
"""

from __future__ import annotations

import logging
import math
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
from scipy import sparse
from scipy.sparse.csgraph import connected_components
from scipy.sparse.linalg import spsolve

from ..errors import InputError

UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001}
MAX_FACES = 4_000_000  # triangles after reading; beyond, the BSDF maps and BVH outgrow a laptop
MAX_FILE_BYTES = 1 << 30
GARMENT_SIZE_M = (0.05, 5.0)  # a bounding-box diagonal outside this is unlikely for a garment
#: a bounding-box diagonal outside this is refused: no garment, and at 1e-30 m the faces' areas
#: underflow, at 1e20 m xatlas never returns (float32 normals that cannot be normalised)
MESH_SIZE_M = (1e-4, 1e4)
#: from this many triangles (or this many bytes of file), each step of reading says so: a
#: 2-million-triangle mesh takes minutes
LARGE_FACES = 200_000
LARGE_FILE_BYTES = 20 << 20
MIN_UV_FACES = 0.5  # with UVs on fewer faces than this share, the layout is made anew
ANCHOR = 1e-9  # weight of the pull towards the layout that pins each island's translation


@dataclass
class RenderMesh:
    """A cleaned triangle mesh with fabric coordinates.

    Attributes
    ----------
    path : the file read
    positions : (V, 3) float64, metres
    faces : (F, 3) int64
    normals : (V, 3) float64, unit, area-weighted over the faces around each position (smooth
        across UV seams)
    uv : (V, 2) float64, fabric coordinates in metres (see the module docstring)
    objects : names of the objects rendered
    uv_source : ``"file"`` or ``"xatlas"``
    stretch : dict with ``before`` and ``after``: the 95th percentile over the surface of each
        face's stretch ``max(σ₁, 1/σ₂)`` (σ the singular values of the map from the surface to
        the fabric's coordinates; 1 = no stretch), of the layout scaled to the surface's area,
        and of the corrected coordinates; ``islands``, ``mirrored_islands``, ``mirrored_faces``
    notes : what was repaired, generated or doubted, one sentence each
    """

    path: Path
    positions: np.ndarray
    faces: np.ndarray
    normals: np.ndarray
    uv: np.ndarray
    objects: list[str]
    uv_source: str
    stretch: dict
    notes: list[str] = field(default_factory=list)

    @property
    def bounds(self) -> np.ndarray:
        """(2, 3): the bounding box's lowest and highest corner, metres."""
        return np.stack([self.positions.min(axis=0), self.positions.max(axis=0)])

    @property
    def area(self) -> float:
        """Surface area, m²."""
        p = self.positions[self.faces]
        return float(np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1).sum() / 2)

    def to_mitsuba(self, bsdf, name: str = "garment"):
        """The mesh as a ``mi.Mesh`` carrying ``bsdf`` (positions, normals, fabric UVs)."""
        from ..backend import mitsuba

        mi = mitsuba()
        props = mi.Properties()
        props["bsdf"] = bsdf
        mesh = mi.Mesh(name, self.positions.shape[0], self.faces.shape[0], props=props, has_vertex_normals=True,
                       has_vertex_texcoords=True)
        params = mi.traverse(mesh)
        params["vertex_positions"] = mi.Float(self.positions.astype(np.float32).ravel())
        params["faces"] = mi.UInt32(self.faces.astype(np.uint32).ravel())
        params["vertex_normals"] = mi.Float(self.normals.astype(np.float32).ravel())
        params["vertex_texcoords"] = mi.Float(self.uv.astype(np.float32).ravel())
        params.update()
        return mesh


# ---------------------------------------------------------------------------------------------
# reading


def _bad_obj_index(path: Path) -> str:
    """The first OBJ face line whose vertex index is out of range, for the message."""
    vertices = 0
    with path.open("r", errors="replace") as fh:
        for number, line in enumerate(fh, 1):
            if line.startswith("v "):
                vertices += 1
            elif line.startswith("f "):
                for ref in line.split()[1:]:
                    try:
                        i = int(ref.split("/")[0])
                    except ValueError:
                        return f"line {number} has a face corner {ref!r} that is not a vertex index"
                    if i == 0 or i > vertices or i < -vertices:
                        return (f"line {number}: face refers to vertex {i}, but only {vertices} vertices are "
                                "defined before it")
    return "a face refers to a vertex that does not exist"


def _sniff(path: Path) -> None:
    """Refuse a file that cannot be the mesh its suffix says, before trimesh guesses at it (it
    blamed random bytes in an ``.obj`` on a missing ``charset_normalizer``)."""
    with path.open("rb") as fh:
        head = fh.read(1 << 16)
    if path.suffix.lower() == ".ply":
        if not head.startswith(b"ply"):
            raise InputError(f"{path}: not a readable PLY mesh: a PLY file starts with the line 'ply'; give an OBJ "
                             "or PLY mesh")
    elif b"\0" in head:
        raise InputError(f"{path}: not a readable OBJ mesh: an OBJ file is text, this one holds binary data; give "
                         "an OBJ or PLY mesh")


def _read(path: Path):
    """trimesh's scene of the file (objects kept apart), or InputError."""
    import trimesh

    _sniff(path)
    logging.getLogger("trimesh").setLevel(logging.ERROR)  # a missing .mtl is not the user's problem here
    try:
        with warnings.catch_warnings():  # trimesh's own numerical chatter on meshes without UVs
            warnings.simplefilter("ignore", RuntimeWarning)
            scene = trimesh.load_scene(str(path), process=False, split_objects=True, group_material=False,
                                       skip_materials=True)
    except IndexError:
        raise InputError(f"{path}: face indices out of range: {_bad_obj_index(path)}; fix or re-export the "
                         "mesh") from None
    except Exception as exc:  # noqa: BLE001 - any parser failure means "not a mesh we can read"
        why = "" if isinstance(exc, ImportError) else f" ({type(exc).__name__}: {exc})"  # trimesh's, not the file's
        raise InputError(f"{path}: not a readable {path.suffix[1:].upper()} mesh{why}; give an OBJ or PLY file of "
                         "triangles or polygons") from None
    return scene


def _objects(path: Path, scene, object_name: str | None) -> list[tuple[str, object]]:
    """The (name, Trimesh) pairs to render: those with faces, or the one named."""
    import trimesh

    meshes = [(name, geom) for name, geom in scene.geometry.items()
              if isinstance(geom, trimesh.Trimesh) and len(geom.faces)]
    if not meshes:
        points = sum(len(getattr(g, "vertices", ())) for g in scene.geometry.values())
        what = f"{points} points and no faces" if points else "nothing that is a mesh"
        raise InputError(f"{path}: the file holds {what}; give a mesh with faces (OBJ or PLY)")
    if object_name is None:
        return meshes
    chosen = [(n, g) for n, g in meshes if n == object_name]
    if not chosen:
        names = ", ".join(n for n, _ in meshes)
        raise InputError(f"{path}: no object named {object_name!r}; the file has: {names}")
    return chosen


def _checked(path: Path, name: str, geom) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, str]:
    """(vertices, faces, uv or None, why the file's UVs are not used or ``""``) of one object,
    refusing NaN/Inf vertices and bad indices."""
    vertices = np.asarray(geom.vertices, dtype=np.float64)
    faces = np.asarray(geom.faces, dtype=np.int64)
    where = f"{path}" + (f" (object {name})" if name else "")
    bad = ~np.isfinite(vertices).all(axis=1)
    if bad.any():
        raise InputError(f"{where}: {int(bad.sum())} vertices are not finite numbers (NaN or infinity), the first "
                         f"is vertex {int(np.flatnonzero(bad)[0]) + 1}; fix or re-export the mesh")
    if faces.size and (faces.min() < 0 or faces.max() >= len(vertices)):
        raise InputError(f"{where}: face indices out of range: a face refers to vertex {int(faces.max()) + 1} but "
                         f"there are {len(vertices)} vertices; fix or re-export the mesh")
    uv = getattr(geom.visual, "uv", None)
    why = "the file has no texture coordinates"
    if uv is not None:
        uv = np.asarray(uv, dtype=np.float64)
        if uv.shape != (len(vertices), 2):
            uv, why = None, "the file's texture coordinates do not match its vertices"
        elif not np.isfinite(uv).all():
            bad = int((~np.isfinite(uv)).any(axis=1).sum())
            uv, why = None, f"{bad} of the file's texture coordinates are NaN or infinite"
        else:
            why = ""
    return vertices, faces, uv, why


def _clean(vertices, faces, uv, notes: list[str]):
    """Drop degenerate faces, merge duplicate vertices (same position and UV), drop unused ones."""
    key = vertices if uv is None else np.concatenate([vertices, uv], axis=1)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.ravel()
    merged = len(vertices) - len(first)
    faces = inverse[faces]
    vertices = vertices[first]
    uv = None if uv is None else uv[first]
    p = vertices[faces]
    area2 = np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    scale = float(np.ptp(vertices, axis=0).max()) if len(vertices) else 0.0
    degenerate = (faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (faces[:, 0] == faces[:, 2]) \
        | (area2 <= 1e-12 * scale * scale)
    faces = faces[~degenerate]
    used = np.unique(faces)
    remap = np.full(len(vertices), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    if merged:
        notes.append(f"merged {merged} duplicate vertices")
    if degenerate.any():
        notes.append(f"dropped {int(degenerate.sum())} degenerate faces (zero area)")
    return vertices[used], remap[faces], None if uv is None else uv[used]


def _smooth_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area-weighted vertex normals over faces sharing a position (so UV seams stay smooth)."""
    _, inverse = np.unique(vertices, axis=0, return_inverse=True)
    inverse = inverse.ravel()
    p = vertices[faces]
    face_n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])  # length = 2 × area
    acc = np.zeros((inverse.max() + 1, 3))
    for k in range(3):
        np.add.at(acc, inverse[faces[:, k]], face_n)
    n = acc[inverse]
    length = np.linalg.norm(n, axis=1, keepdims=True)
    return np.where(length > 0, n / np.maximum(length, 1e-300), (0.0, 0.0, 1.0))


# ---------------------------------------------------------------------------------------------
# fabric coordinates


def _face_frames(vertices: np.ndarray, faces: np.ndarray):
    """Each face's corners in a 2D orthonormal frame of its plane ((F, 3, 2)) and its area."""
    p = vertices[faces]
    e1 = p[:, 1] - p[:, 0]
    n = np.cross(e1, p[:, 2] - p[:, 0])
    area = np.linalg.norm(n, axis=1) / 2
    x = e1 / np.maximum(np.linalg.norm(e1, axis=1, keepdims=True), 1e-300)
    y = np.cross(n / np.maximum(2 * area[:, None], 1e-300), x)
    local = np.stack([np.einsum("fkd,fd->fk", p - p[:, :1], x), np.einsum("fkd,fd->fk", p - p[:, :1], y)], axis=-1)
    return local, area


def _jacobians(local: np.ndarray, uv: np.ndarray, faces: np.ndarray):
    """Per face, the 2×2 map J from the face's local coordinates to UV, and its determinant."""
    q = uv[faces]
    dp = np.stack([local[:, 1] - local[:, 0], local[:, 2] - local[:, 0]], axis=-1)  # (F, 2, 2) columns
    dq = np.stack([q[:, 1] - q[:, 0], q[:, 2] - q[:, 0]], axis=-1)
    det_p = dp[:, 0, 0] * dp[:, 1, 1] - dp[:, 0, 1] * dp[:, 1, 0]
    inv = np.stack([np.stack([dp[:, 1, 1], -dp[:, 0, 1]], -1), np.stack([-dp[:, 1, 0], dp[:, 0, 0]], -1)], 1)
    inv = inv / np.where(np.abs(det_p) > 0, det_p, 1.0)[:, None, None]
    jac = dq @ inv
    return jac, np.linalg.det(jac)


def _stretch(jac: np.ndarray, area: np.ndarray, ok: np.ndarray) -> float:
    """95th area-weighted percentile of max(σ₁, 1/σ₂) of the faces' maps (1 = isometric)."""
    if not ok.any():
        return float("nan")
    s = np.linalg.svd(jac[ok], compute_uv=False)
    worst = np.maximum(s[:, 0], 1.0 / np.maximum(s[:, 1], 1e-12))
    order = np.argsort(worst)
    weight = np.cumsum(area[ok][order])
    return float(worst[order][np.searchsorted(weight, 0.95 * weight[-1])])


def _gradient_operator(local: np.ndarray, area: np.ndarray, faces: np.ndarray, n_vertices: int):
    """Sparse (2F, V) operator: the gradient, in each face's local frame, of a function linear
    over the face with the given vertex values (rows 2f, 2f+1: d/dx, d/dy)."""
    x, y = local[..., 0], local[..., 1]
    rows, cols, vals = [], [], []
    twice = np.maximum(2 * area, 1e-300)
    for k in range(3):
        a, b = (k + 1) % 3, (k + 2) % 3
        # ∇N_k = perp(x_b - x_a) / (2 area), perp(v) = (-v_y, v_x) for counter-clockwise corners
        gx = -(y[:, b] - y[:, a]) / twice
        gy = (x[:, b] - x[:, a]) / twice
        f = np.arange(len(faces))
        rows += [2 * f, 2 * f + 1]
        cols += [faces[:, k], faces[:, k]]
        vals += [gx, gy]
    return sparse.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                             shape=(2 * len(faces), n_vertices))


def fabric_coordinates(vertices: np.ndarray, faces: np.ndarray, uv: np.ndarray) -> tuple[np.ndarray, dict]:
    """Coordinates in metres that follow the layout ``uv`` (any units) without its stretch.

    An island (faces connected through shared vertices) laid out mirrored — most of its area
    with the layout's orientation opposite to the faces' winding — is mirrored back (u → -u),
    so the fabric's face is on the normals' side. Per face the closest rotation ``R_f`` to the
    layout's map (polar decomposition; a face still mirrored gets the closest proper rotation),
    then one sparse least-squares solve ``min Σ_f area_f ‖∇u - R_f‖²`` (the weight ANCHOR pulls
    each island to the layout's scaled position, fixing its translation).

    Returns
    -------
    coords : (V, 2) float64, metres
    stretch : {"before", "after"} (see :class:`RenderMesh`), and ``mirrored`` faces corrected
    """
    local, area = _face_frames(vertices, faces)
    uv = uv.copy()
    jac, det = _jacobians(local, uv, faces)
    n_islands, island = connected_components(
        sparse.coo_matrix((np.ones(2 * len(faces)), (np.concatenate([faces[:, 0], faces[:, 1]]),
                                                     np.concatenate([faces[:, 1], faces[:, 2]]))),
                          shape=(len(vertices),) * 2), directed=False)
    face_island = island[faces[:, 0]]
    signed = np.bincount(face_island, weights=np.sign(det) * area, minlength=n_islands)
    mirrored_islands = signed < 0
    if mirrored_islands.any():
        uv[mirrored_islands[island], 0] *= -1.0
        jac, det = _jacobians(local, uv, faces)
    ok = (area > 0) & np.isfinite(det) & (np.abs(det) > 0)
    uv_area = np.abs(det) * area
    scale = math.sqrt(area[ok].sum() / max(uv_area[ok].sum(), 1e-300))  # layout units → metres, overall
    before = _stretch(jac * scale, area, ok)
    u_, _, vt = np.linalg.svd(jac[ok])
    rot = np.zeros_like(jac)
    r = u_ @ vt
    flip = np.linalg.det(r) < 0
    u_[flip, :, 1] *= -1  # the closest proper rotation: flip the weaker direction
    rot[ok] = u_ @ vt
    weight = np.where(ok, area, 0.0)
    g = _gradient_operator(local, area, faces, len(vertices))
    w = sparse.diags(np.repeat(weight, 2))
    laplacian = (g.T @ w @ g).tocsc()
    anchor = ANCHOR * float(laplacian.diagonal().mean())
    lhs = (laplacian + anchor * sparse.identity(len(vertices))).tocsc()
    coords = np.empty((len(vertices), 2))
    for c in range(2):
        target = rot[:, c, :].reshape(-1)  # ∇ of coordinate c: row c of R_f, as (d/dx, d/dy)
        rhs = g.T @ (np.repeat(weight, 2) * target) + anchor * (uv[:, c] * scale)
        coords[:, c] = spsolve(lhs, rhs)
    jac_after, _ = _jacobians(local, coords, faces)
    return coords, {"before": before, "after": _stretch(jac_after, area, ok), "islands": int(n_islands),
                    "mirrored_islands": int(mirrored_islands.sum()), "mirrored_faces": int(flip.sum())}


def _uv_area_share(vertices: np.ndarray, faces: np.ndarray, uv: np.ndarray) -> float:
    """The share of the surface's area on faces whose UV triangle has an area (not all at one
    point, not on a line), relative to the layout's extent."""
    q = uv[faces]
    a, b = q[:, 1] - q[:, 0], q[:, 2] - q[:, 0]
    uv_area = np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])
    extent = float(np.ptp(uv, axis=0).max()) if len(uv) else 0.0
    p = vertices[faces]
    area = np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    return float(area[uv_area > 1e-12 * extent * extent].sum() / max(area.sum(), 1e-300))


def _generate_uvs(vertices: np.ndarray, faces: np.ndarray, normals: np.ndarray):
    """xatlas charts: (vertices, faces, normals, uv) with vertices split along chart seams.

    xatlas gets the mesh centred and scaled to a unit box (its charts do not depend on the
    scale), in float32 well within range: far from the origin or at 1e20 its normals could not
    be normalised and it never returned."""
    import xatlas

    centre = (vertices.min(axis=0) + vertices.max(axis=0)) / 2
    size = max(float(np.ptp(vertices, axis=0).max()), 1e-300)
    vmap, new_faces, uv = xatlas.parametrize(((vertices - centre) / size).astype(np.float32), faces.astype(np.uint32))
    return vertices[vmap], new_faces.astype(np.int64), normals[vmap], uv.astype(np.float64)


# ---------------------------------------------------------------------------------------------


def load_mesh(path, *, units: str = "m", object_name: str | None = None,
              progress: Callable[[str], None] | None = None) -> RenderMesh:
    """Read, check, clean and measure a mesh, with fabric coordinates in metres.

    Parameters
    ----------
    path : OBJ or PLY file
    units : the file's length unit, ``m``, ``cm`` or ``mm``
    object_name : render only this object of a multi-object OBJ (default: every object)
    progress : called with a line before each step of a large mesh (:data:`LARGE_FACES`
        triangles or :data:`LARGE_FILE_BYTES` of file), each saying what it does and the
        time so far

    Raises
    ------
    InputError
        Missing, empty, oversized or unreadable file; not a mesh; no faces; NaN/Inf vertices;
        face indices out of range; more than MAX_FACES faces; a size or a distance from the
        origin outside MESH_SIZE_M; unknown ``units`` or object.
    """
    p = Path(path)
    t0 = time.perf_counter()
    if units not in UNITS:
        raise InputError(f"--units {units!r} is unknown; use one of {', '.join(UNITS)}")
    if p.is_dir():
        raise InputError(f"{p}: is a folder; give the path of an OBJ or PLY mesh file")
    if not p.exists():
        raise InputError(f"{p}: mesh file not found")
    if not p.is_file():
        raise InputError(f"{p}: is not a regular file (a device or a pipe); give an OBJ or PLY mesh file")
    size = p.stat().st_size
    if size == 0:
        raise InputError(f"{p}: the file is empty; give an OBJ or PLY mesh")
    if size > MAX_FILE_BYTES:
        raise InputError(f"{p}: {size / 2**30:.1f} GiB is over the mesh size limit of {MAX_FILE_BYTES / 2**30:.0f} GiB; "
                         "decimate the mesh first")
    if p.suffix.lower() not in (".obj", ".ply"):
        raise InputError(f"{p}: unsupported mesh format {p.suffix or '(none)'!r}; give an OBJ or PLY file")
    large = size >= LARGE_FILE_BYTES

    def step(what: str) -> None:
        if large and progress is not None:
            progress(f"{what} ({time.perf_counter() - t0:.1f} s so far)")

    step(f"reading {size / 2**20:.0f} MB")
    objects = _objects(p, _read(p), object_name)
    notes: list[str] = []
    total = sum(len(g.faces) for _, g in objects)
    if total > MAX_FACES:
        raise InputError(f"{p}: {total} faces is over the mesh size limit of {MAX_FACES}; decimate the mesh first")
    large = large or total >= LARGE_FACES
    parts, names = [], []
    for name, geom in objects:
        parts.append(_checked(p, name if len(objects) > 1 else "", geom))
        names.append(name)
    with_uv = sum(len(f) for _, f, uv, _ in parts if uv is not None)
    use_file_uvs = with_uv >= MIN_UV_FACES * total and all(uv is not None for _, _, uv, _ in parts)
    vertices, faces, uvs, offset = [], [], [], 0
    for v, f, uv, _ in parts:
        vertices.append(v)
        faces.append(f + offset)
        uvs.append(uv if use_file_uvs else np.zeros((len(v), 2)))
        offset += len(v)
    vertices, faces, uv = np.concatenate(vertices), np.concatenate(faces), np.concatenate(uvs)
    diagonal = float(np.linalg.norm(np.ptp(vertices, axis=0))) * UNITS[units]
    if not MESH_SIZE_M[0] <= diagonal <= MESH_SIZE_M[1]:
        raise InputError(f"{p}: the mesh is {diagonal:.3g} m across in --units {units}, outside "
                         f"{MESH_SIZE_M[0] * 1000:g} mm to {MESH_SIZE_M[1] / 1000:g} km; check --units (m, cm, mm) "
                         "or rescale the mesh")
    reach = float(np.abs(vertices).max()) * UNITS[units]
    if reach > MESH_SIZE_M[1]:  # the renderer's float32 would merge its vertices
        raise InputError(f"{p}: the mesh lies up to {reach:.3g} m from the origin, beyond "
                         f"{MESH_SIZE_M[1] / 1000:g} km; move it near the origin (the renderer works in 32-bit floats)")
    step(f"cleaning {total} triangles")
    vertices, faces, uv = _clean(vertices * UNITS[units], faces, uv if use_file_uvs else None, notes)
    if not len(faces):
        raise InputError(f"{p}: every face is degenerate (zero area); nothing to render")
    normals = _smooth_normals(vertices, faces)
    why = next((w for _, _, _, w in parts if w), "texture coordinates cover too few faces")
    if use_file_uvs:
        share = _uv_area_share(vertices, faces, uv)
        if share < MIN_UV_FACES:
            use_file_uvs = False
            why = (f"the file's texture coordinates have no area on {1 - share:.0%} of the surface (all at one point, "
                   "or on a line)")
    if use_file_uvs:
        source = "file"
    else:
        step(f"making UVs with xatlas for {len(faces)} triangles")
        vertices, faces, normals, uv = _generate_uvs(vertices, faces, normals)
        source = "xatlas"
        notes.append(f"generated UVs with xatlas ({why})")
    step("solving the fabric coordinates")
    coords, stretch = fabric_coordinates(vertices, faces, uv)
    if stretch["mirrored_islands"] and source == "file":
        notes.append(f"{stretch['mirrored_islands']} of {stretch['islands']} UV islands are laid out mirrored; the "
                     "fabric's face is put on the side the normals point to")
    diagonal = float(np.linalg.norm(np.ptp(vertices, axis=0)))
    lo, hi = GARMENT_SIZE_M
    if not lo <= diagonal <= hi:
        notes.append(f"warning: the mesh is {diagonal:.3g} m across in --units {units}, which is unlikely for a "
                     "garment; check --units (m, cm, mm)")
    step("read")
    return RenderMesh(path=p, positions=vertices, faces=faces, normals=normals, uv=coords, objects=names,
                      uv_source=source, stretch=stretch, notes=notes)
