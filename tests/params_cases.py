"""A catalogue of bad params files: every bad file a user might hand to weavecap, as edits of
the bundled fixture plain.json, with what the error message must say.

Used through the ``bad_params`` fixture of ``conftest.py`` by the library tests
(``test_params.py``) and the command tests (``cli/test_cli_errors.py``), and directly
(:func:`bad_params_text`) by the batch tests; a module of its own, since a test module's
``from conftest import`` can find another folder's conftest first.
"""

from __future__ import annotations

import copy
import json
from dataclasses import dataclass
from pathlib import Path

FIXTURE_PARAMS = Path(__file__).resolve().parents[1] / "fixtures" / "params"

DELETE = object()  # as an edit's value: remove the key
TRUNCATE = "truncate"  # as an edit: cut the JSON text in half


@dataclass(frozen=True)
class BadParams:
    """A params file with one thing wrong, and what the error message must say about it.

    ``field`` is the dotted field the error names ("" when the file is not JSON at all);
    ``words`` must all appear in the message (the value and the allowed range).
    """

    path: Path
    field: str
    words: tuple[str, ...]


# id, edit of fixtures/params/plain.json (dotted key -> new value), field named, words in message
BAD_PARAMS = [
    ("truncated-json", TRUNCATE, "", ("not valid JSON", "line")),
    ("ior-above-range", {"specular.ior": 3.5}, "specular.ior", ("3.5", "[1, 3]")),
    ("plies-above-range", {"plies": 9}, "plies", ("9", "[1, 7]")),
    ("fibers-below-range", {"fibers": 10}, "fibers", ("10", "[20, 50]")),
    ("radius-not-positive", {"warp.radius": -1.0}, "warp.radius", ("-1.0", "> 0")),
    ("colour-channel-above-1", {"specular.reflection": [0.5, 1.5, 0.5]}, "specular.reflection[1]",
     ("1.5", "[0, 1]")),
    ("body-colour-channel-negative", {"weft.body_reflection": [0.2, -0.1, 0.2]}, "weft.body_reflection[1]",
     ("-0.1", "[0, 1]")),
    ("colour-of-two-channels", {"warp.body_subsurface": [0.2, 0.2]}, "warp.body_subsurface", ("[0.2, 0.2]", "3")),
    ("pattern-cell-2", {"pattern": [[1, 0], [2, 1]]}, "pattern[1][0]", ("2", "0, 1")),
    ("pattern-cell-half", {"pattern": [[1, 0.5], [0, 1]]}, "pattern[0][1]", ("0.5", "0, 1")),
    ("pattern-not-rectangular", {"pattern": [[1, 0, 1], [0, 1]]}, "pattern[1]", ("rectangular",)),
    ("pattern-empty", {"pattern": []}, "pattern", ("1 to 64",)),
    ("pattern-too-wide", {"pattern": [[0, 1] * 33]}, "pattern[0]", ("1 to 64",)),
    ("roughness-nan", {"specular.roughness": float("nan")}, "specular.roughness", ("NaN", "[0, 1]")),
    ("shadowing-infinity", {"shadowing.ply": float("inf")}, "shadowing.ply", ("infinity", "[0, 1]")),
    ("colour-minus-infinity", {"warp.body_subsurface": [0.1, 0.1, float("-inf")]}, "warp.body_subsurface[2]",
     ("infinity", "[0, 1]")),
    ("missing-required-field", {"specular.ior": DELETE}, "specular.ior", ("missing", "[1, 3]")),
    ("missing-top-level-field", {"plies": DELETE}, "plies", ("missing", "[1, 7]")),
    ("plies-as-text", {"plies": "three"}, "plies", ('"three"', "integer", "[1, 7]")),
    ("plies-fractional", {"plies": 2.5}, "plies", ("2.5", "integer")),
    ("section-wrong-type", {"shadowing": "strong"}, "shadowing", ('"strong"', "object")),
    ("unknown-top-level-key", {"colour": [1, 0, 0]}, "(top level)", ("colour", "extra")),
    ("wrong-format", {"format": "weavecap.params/0"}, "format", ("weavecap.params/1",)),
    ("texture-missing", {"warp.body_reflection": "no_such_texture.png"}, "warp.body_reflection",
     ("no_such_texture.png", "does not exist")),
]


def _edit(doc: dict, key: str, value) -> None:
    node = doc
    parts = key.split(".")
    for part in parts[:-1]:
        node = node[part]
    if value is DELETE:
        del node[parts[-1]]
    else:
        node[parts[-1]] = value


def bad_params_text(edit) -> str:
    """The JSON text of plain.json with ``edit`` applied (NaN/Infinity as JSON's literals)."""
    doc = copy.deepcopy(json.loads((FIXTURE_PARAMS / "plain.json").read_text()))
    if edit == TRUNCATE:
        text = json.dumps(doc, indent=1)
        return text[: len(text) // 2]
    for key, value in edit.items():
        _edit(doc, key, value)
    return json.dumps(doc, indent=1)
