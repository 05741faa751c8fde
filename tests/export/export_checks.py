"""Helpers shared by the export tests: the glTF validator (Node), U3M schemas, map readers."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
#: the published U3M 1.1 schema (vizoogmbh/u3m, BSD-3-Clause), under ../shared
PUBLISHED_U3M_SCHEMA = ("u3m", "u3m_schema.json")
OWN_U3M_SCHEMA = ROOT / "weavecap" / "schemas" / "u3m-1.1.schema.json"
GLTF_VALIDATOR = "gltf-validator@2.0.0-dev.3.10"  # the Khronos validator compiled to JS (npm)
NODE_DIR = ROOT / "build" / "node"  # ignored by git (/build/)

VALIDATE_JS = """
const fs = require('fs');
const validator = require(process.argv[2]);
validator.validateBytes(new Uint8Array(fs.readFileSync(process.argv[3])), {maxIssues: 200})
  .then((report) => console.log(JSON.stringify(report)))
  .catch((error) => { console.error(String(error)); process.exit(1); });
"""


def gltf_validator() -> Path | None:
    """The validator's module folder, installed from npm into build/node on first use; None
    where Node or npm is missing or the install fails (no network)."""
    module = NODE_DIR / "node_modules" / "gltf-validator"
    if module.is_dir():
        return module
    if not (shutil.which("node") and shutil.which("npm")):
        return None
    NODE_DIR.mkdir(parents=True, exist_ok=True)
    done = subprocess.run(["npm", "install", "--prefix", str(NODE_DIR), "--no-audit", "--no-fund", GLTF_VALIDATOR],
                          capture_output=True, text=True, timeout=300)
    return module if done.returncode == 0 and module.is_dir() else None


def validate_gltf(module: Path, path: Path) -> dict:
    """The Khronos validator's report of a .glb/.gltf file (JSON, as the validator gives it)."""
    script = NODE_DIR / "validate.js"
    script.write_text(VALIDATE_JS)
    done = subprocess.run(["node", str(script), str(module), str(path)], capture_output=True, text=True, timeout=300,
                          check=True)
    return json.loads(done.stdout)


def read_png(path: Path) -> np.ndarray:
    """A PNG's stored values in [0, 1] (no colour decoding), RGB(A) order."""
    import cv2

    a = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    top = 255.0 if a.dtype == np.uint8 else 65535.0
    if a.ndim == 3:
        a = a[..., [2, 1, 0, 3][: a.shape[2]]]
    return a.astype(np.float64) / top


def validator_for(schema_path: Path):
    import jsonschema

    schema = json.loads(schema_path.read_text())
    cls = jsonschema.validators.validator_for(schema)
    return cls(schema, format_checker=cls.FORMAT_CHECKER)
