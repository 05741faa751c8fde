"""glTF 2.0 swatch for web viewers and game engines: a flat square of fabric with its material.

One ``.glb`` file (pygltflib): a quad ``swatch_mm`` wide lying in the ground plane (glTF is
+y up, metres), facing up and seen from both sides; a metal-roughness material whose base
colour texture carries the opacity in its alpha (``BLEND``: the gaps between yarns show what is
behind), a roughness texture (green channel, metalness 0 in blue), the normal map (OpenGL, as
glTF wants it); every texture repeats ``k`` times across the swatch through
``KHR_texture_transform`` (required: without it one tile would be stretched over the swatch);
``KHR_materials_ior`` and ``KHR_materials_specular`` give the yarns' specular reflectance.
No ``KHR_materials_sheen``: measured against the surface model, a sheen makes the swatch look
less like it at every view (docs/export.md). The texture's top row lies towards
−z, so a viewer looking down with −z up sees the tile as in the PNG maps.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .maps import PbrMaps, map_image

#: default side of the swatch, millimetres (rounded to whole tiles)
SWATCH_MM = 100.0
TRANSFORM = "KHR_texture_transform"
IOR, SPECULAR = "KHR_materials_ior", "KHR_materials_specular"


def _png(image: np.ndarray, *, srgb_channels: int) -> bytes:
    """8-bit PNG bytes of a [0, 1] image (H, W, C): the first ``srgb_channels`` sRGB-encoded."""
    import cv2

    from ..photo import linear_to_srgb

    a = np.clip(np.asarray(image, dtype=np.float32), 0.0, 1.0).copy()
    if srgb_channels:
        a[..., :srgb_channels] = linear_to_srgb(a[..., :srgb_channels])
    q = np.rint(a * 255.0).astype(np.uint8)
    order = [2, 1, 0, 3][: q.shape[2]] if q.shape[2] in (3, 4) else list(range(q.shape[2]))
    ok, buf = cv2.imencode(".png", np.ascontiguousarray(q[..., order]))
    if not ok:
        raise RuntimeError(f"OpenCV could not encode a PNG of shape {q.shape}")
    return buf.tobytes()


def swatch_tiles(maps: PbrMaps, swatch_mm: float = SWATCH_MM) -> tuple[int, int]:
    """Whole tiles (across, down) that make a swatch about ``swatch_mm`` wide and as high."""
    return (max(1, round(swatch_mm / maps.size_mm[0])), max(1, round(swatch_mm / maps.size_mm[1])))


def gltf_swatch(maps: PbrMaps, *, name: str, swatch_mm: float = SWATCH_MM, extras: dict | None = None):
    """The swatch as a :class:`pygltflib.GLTF2` with its binary buffer set (write with
    ``save_binary``)."""
    import pygltflib as g

    across, down = swatch_tiles(maps, swatch_mm)
    w = across * maps.size_mm[0] / 1000.0  # metres
    h = down * maps.size_mm[1] / 1000.0
    positions = np.array([[-w / 2, 0, -h / 2], [w / 2, 0, -h / 2], [w / 2, 0, h / 2], [-w / 2, 0, h / 2]], np.float32)
    normals = np.tile(np.array([0, 1, 0], np.float32), (4, 1))
    tangents = np.tile(np.array([1, 0, 0, 1], np.float32), (4, 1))  # +u along +x; bitangent n × t = −z (up the image)
    uvs = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32)
    indices = np.array([0, 3, 2, 0, 2, 1], np.uint16)  # counter-clockwise seen from +y

    opacity = map_image(maps, "opacity")[..., None]
    images = {
        "base_color": _png(np.concatenate([map_image(maps, "base_color"), opacity], axis=-1), srgb_channels=3),
        "roughness": _png(np.stack([np.zeros_like(maps.roughness), map_image(maps, "roughness"),
                                    np.zeros_like(maps.roughness)], axis=-1), srgb_channels=0),
        "normal": _png(map_image(maps, "normal"), srgb_channels=0),
    }

    blob = bytearray()
    views = []

    def add(data: bytes, target: int | None = None) -> int:
        while len(blob) % 4:
            blob.append(0)
        views.append(g.BufferView(buffer=0, byteOffset=len(blob), byteLength=len(data), target=target))
        blob.extend(data)
        return len(views) - 1

    accessors = []
    for array, kind in ((positions, g.VEC3), (normals, g.VEC3), (tangents, g.VEC4), (uvs, g.VEC2)):
        view = add(array.tobytes(), g.ARRAY_BUFFER)
        accessors.append(g.Accessor(bufferView=view, componentType=g.FLOAT, count=len(array), type=kind,
                                    min=array.min(axis=0).tolist() if kind == g.VEC3 and array is positions else None,
                                    max=array.max(axis=0).tolist() if kind == g.VEC3 and array is positions else None))
    accessors.append(g.Accessor(bufferView=add(indices.tobytes(), g.ELEMENT_ARRAY_BUFFER),
                                componentType=g.UNSIGNED_SHORT, count=len(indices), type=g.SCALAR))
    image_index = {}
    gl_images = []
    for key, data in images.items():
        image_index[key] = len(gl_images)
        gl_images.append(g.Image(bufferView=add(data), mimeType="image/png", name=f"{name}_{key}"))

    transform = {TRANSFORM: {"scale": [float(across), float(down)]}}

    def info(key: str, cls=g.TextureInfo, **kw):
        return cls(index=image_index[key], extensions=dict(transform), **kw)

    material = g.Material(
        name=name, doubleSided=True, alphaMode="BLEND",
        pbrMetallicRoughness=g.PbrMetallicRoughness(baseColorTexture=info("base_color"), metallicFactor=1.0,
                                                   roughnessFactor=1.0, metallicRoughnessTexture=info("roughness")),
        normalTexture=info("normal", g.NormalMaterialTexture, scale=1.0),
        # F0 = F0(η^S) × R^S, as the material was fitted with (core glTF: 4 %)
        extensions={IOR: {"ior": float(maps.ior)}, SPECULAR: {"specularFactor": float(maps.specular)}})
    gltf = g.GLTF2(
        asset=g.Asset(version="2.0", generator=f"weavecap {_version()}"),
        scene=0, scenes=[g.Scene(nodes=[0])], nodes=[g.Node(mesh=0, name=name)],
        meshes=[g.Mesh(name=name, primitives=[g.Primitive(
            attributes=g.Attributes(POSITION=0, NORMAL=1, TANGENT=2, TEXCOORD_0=3), indices=4, material=0)])],
        accessors=accessors, bufferViews=views, buffers=[g.Buffer(byteLength=len(blob))],
        images=gl_images, samplers=[g.Sampler(magFilter=g.LINEAR, minFilter=g.LINEAR_MIPMAP_LINEAR,
                                              wrapS=g.REPEAT, wrapT=g.REPEAT)],
        textures=[g.Texture(source=i, sampler=0) for i in range(len(gl_images))],
        materials=[material], extensionsUsed=[TRANSFORM, IOR, SPECULAR], extensionsRequired=[TRANSFORM],
        extras={"swatch_mm": [round(w * 1000, 6), round(h * 1000, 6)], "tile_mm": list(maps.size_mm),
                **(extras or {})})
    gltf.set_binary_blob(bytes(blob))
    return gltf


def _version() -> str:
    from .. import __version__

    return __version__


def save_gltf(maps: PbrMaps, path: Path, *, name: str, swatch_mm: float = SWATCH_MM, extras: dict | None = None) -> Path:
    """Write the swatch as one binary glTF file, atomically."""
    from ..io import atomic_path

    gltf = gltf_swatch(maps, name=name, swatch_mm=swatch_mm, extras=extras)
    with atomic_path(path) as tmp:
        gltf.save_binary(str(tmp))
    return path

