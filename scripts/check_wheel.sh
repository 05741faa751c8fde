#!/usr/bin/env bash
# Install weavecap the way users do and run it from outside the source tree (issue 16): build a
# wheel, install it, not editable, into a fresh virtual environment, then fit a fixture photo.
# Called by `make test` after the test suite. WHEEL_CHECK_DIR moves the scratch folder.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
work=${WHEEL_CHECK_DIR:-$root/build/wheel-check}
python=${PYTHON:-python3}
rm -rf "$work"
mkdir -p "$work/dist"
"$root/.venv/bin/python" -m pip wheel -q --no-deps -w "$work/dist" "$root"
"$python" -m venv "$work/venv"
"$work/venv/bin/python" -m pip install -q --upgrade pip
# torch first: the pinned CPU build is on disk; anything else would pull CUDA wheels.
"$work/venv/bin/python" -m pip install -q torch==2.13.0
"$work/venv/bin/python" -m pip install -q "$work"/dist/weavecap-*.whl
cd "$work"
bin="$work/venv/bin"
"$bin/python" - <<'PY'
import importlib.util, pathlib, weavecap
here = pathlib.Path(weavecap.__file__).resolve()
assert "site-packages" in here.parts, f"weavecap imported from {here}, not the installed wheel"
for name in ("weavecap.cli.main", "weavecap.fit.joint", "weavecap.estimate.initializer", "weavecap.fixtures",
             "weavecap.render.run", "weavecap.cli.render"):
    assert importlib.util.find_spec(name) is not None, f"the wheel lacks {name}"
from weavecap import fixtures
from weavecap.bench import model as bench_model
assert bench_model.FIXTURE.is_file(), f"bench fixture missing: {bench_model.FIXTURE}"
assert fixtures.path("photos", "twill_3_1.png").is_file()
assert fixtures.path("meshes", "skirt.obj").is_file(), "the wheel lacks the fixture meshes"
from weavecap.render.fold.blidf import weights_path
assert weights_path().is_file(), f"the wheel lacks the fold renderer's weights: {weights_path()}"
woven = pathlib.Path(importlib.util.find_spec("weavecap.render.woven").origin).parent / "weights"
assert any(woven.glob("*.npz")), f"the wheel lacks the woven renderer's weights in {woven}"
PY
test -f "$work/venv/share/man/man1/weavecap-fit.1" || { echo "check_wheel: man pages not installed" >&2; exit 1; }
photo=$("$bin/python" -c 'from weavecap import fixtures; print(fixtures.path("photos", "twill_3_1.png"))')
"$bin/weavecap" fit "$photo" -o fit --quality draft -q
test -s fit/params.json && test -s fit/report.json
echo "check_wheel: the installed wheel fitted $photo ($(cd "$work" && "$bin/python" -c 'import json; r=json.load(open("fit/report.json")); print(r["weave"], r["fit"]["psnr_db"], "dB")'))"
# and the captured fabric on a garment, from the installed wheel, by its packaged neural and fold
# networks (the demo's last step, tiny)
skirt=$("$bin/python" -c 'from weavecap import fixtures; print(fixtures.path("meshes", "skirt.obj"))')
"$bin/weavecap" render fit/params.json "$skirt" -o skirt.png --size 96x72 --pitch-mm 3 --mode neural --fold on -q
test -s skirt.png
"$bin/python" - <<'PY'
import json, sys
image = json.load(open("skirt.png.json"))  # the render's record beside the image
if image["mode"] != "neural" or image["fold"] != "blidf":
    sys.exit(f"check_wheel: the wheel rendered mode {image['mode']} with fold {image['fold']}, not neural + blidf")
PY
echo "check_wheel: the installed wheel rendered fit/params.json on $skirt"
