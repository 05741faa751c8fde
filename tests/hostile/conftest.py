"""What every promise test uses: the command in this process (click's runner) or as a user's
shell runs it (a subprocess, signals and all), and tiny inputs with known outcomes."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from weavecap.cli.main import cli
from weavecap.photo import save_png

ROOT = Path(__file__).resolve().parents[2]
PLAIN = ROOT / "fixtures" / "params" / "plain.json"
SWATCH = ROOT / "fixtures" / "meshes" / "swatch.obj"
PLAIN_PHOTO = ROOT / "fixtures" / "photos" / "plain.png"


def weavecap(*args):
    """``weavecap ARGS`` in this process; ``.output`` holds stdout and stderr."""
    return CliRunner().invoke(cli, [str(a) for a in args])


def shell(*args, env: dict | None = None, cwd: Path | None = None, **popen) -> subprocess.Popen:
    """``weavecap ARGS`` started as a separate process, as from a shell (no traceback asked for)."""
    environ = {k: v for k, v in os.environ.items() if k != "WEAVECAP_DEBUG"}
    return subprocess.Popen([sys.executable, "-m", "weavecap.cli.main", *map(str, args)],
                            env={**environ, **(env or {})}, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, **popen)


def noise_photo(path: Path, seed: int = 0) -> Path:
    """A 64-px photo of noise: preparation rejects it in about half a second (exit 3)."""
    save_png(path, np.random.default_rng(seed).random((64, 64, 3)).astype(np.float32))
    return path


def params_with(tmp_path: Path, name: str, **changes) -> Path:
    """The plain fixture with dotted keys changed (``warp__radius=1e308`` sets warp.radius)."""
    doc = json.loads(PLAIN.read_text())
    for key, value in changes.items():
        node, parts = doc, key.split("__")
        for part in parts[:-1]:
            node = node.setdefault(part, {})
        if value is None:
            node.pop(parts[-1])
        else:
            node[parts[-1]] = value
    path = tmp_path / name
    path.write_text(json.dumps(doc))
    return path


def files_under(folder: Path) -> set[str]:
    """Every file under ``folder``, relative, hidden ones included."""
    return {str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file()}


@pytest.fixture
def sandbox(tmp_path) -> Path:
    """A folder whose every file is accounted for: ``sandbox/out`` is where -o points."""
    (tmp_path / "in").mkdir()
    return tmp_path
