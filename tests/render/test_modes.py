"""The mode table and the fold hook (weavecap.render.modes): another renderer plugs in by
registering, and ``--fold auto|on|off`` applies a fold term where the contract says."""

from __future__ import annotations

import numpy as np
import pytest

from weavecap import params
from weavecap.errors import InputError
from weavecap.fixtures import path as fixture_path
from weavecap.render import modes
from weavecap.render.mesh import load_mesh
from weavecap.render.run import RenderOptions, render_fabric

TINY = dict(size=(24, 16), spp=2)


@pytest.fixture
def registry():
    """The table as it was, restored after the test."""
    saved_modes, saved_terms = dict(modes.MODES), list(modes.FOLD_TERMS)
    yield
    modes.MODES.clear()
    modes.MODES.update(saved_modes)
    modes.FOLD_TERMS[:] = saved_terms


def test_built_in_modes_and_unknown_ones():
    assert modes.mode_names()[:2] == ["reference", "direct"]
    assert "neural" in modes.mode_names()  # the woven renderer registers itself
    with pytest.raises(InputError, match="--mode 'nope' is unknown; available: direct, neural, reference"):
        modes.mode("nope")


def test_a_registered_mode_renders_and_a_fold_term_applies_where_asked(registry):
    """A mode whose BSDF is Mitsuba's diffuse renders through the command's stages; a fold term
    registered beside it doubles the image under --fold on, and under auto only for modes that
    ask for it on meshes with folds."""
    from weavecap.backend import mitsuba

    mi = mitsuba()
    seen = []
    modes.register_mode(modes.Mode("grey", "a test mode", bsdf=lambda *a: mi.load_dict({"type": "diffuse"}),
                                   integrator=lambda lighting, options: {"type": "direct"}, fold=True))
    modes.register_fold_term(modes.FoldTerm("double", has_folds=lambda mesh: len(mesh.faces) > 100,
                                            apply=lambda ctx: seen.append(ctx.mesh) or 2 * ctx.image))
    fabric = params.load(fixture_path("params", "plain.json"))
    folds, flat = load_mesh(fixture_path("meshes", "sine_high.obj")), load_mesh(fixture_path("meshes", "swatch.obj"))
    off = render_fabric(fabric, folds, RenderOptions(mode="grey", fold="off", **TINY))
    auto = render_fabric(fabric, folds, RenderOptions(mode="grey", fold="auto", **TINY))
    assert off.info["fold"] is None and auto.info["fold"] == "double"
    np.testing.assert_allclose(auto.image, 2 * off.image, rtol=1e-6)
    assert render_fabric(fabric, flat, RenderOptions(mode="grey", fold="auto", **TINY)).info["fold"] is None
    assert render_fabric(fabric, folds, RenderOptions(mode="reference", fold="auto", **TINY)).info["fold"] is None
    assert render_fabric(fabric, flat, RenderOptions(mode="reference", fold="on", **TINY)).info["fold"] == "double"
    assert len(seen) == 2


def test_fold_on_without_a_term_is_an_error(registry):
    modes.FOLD_TERMS.clear()
    mesh = load_mesh(fixture_path("meshes", "swatch.obj"))
    with pytest.raises(InputError, match="no fold term is installed"):
        modes.fold_term("on", modes.mode("reference"), mesh)
    assert modes.fold_term("auto", modes.mode("reference"), mesh) is None
