# Set-up and entry points for a fresh machine. See README.md.
#   make demo   install, fit the bundled fixture photo (the main job), re-render it, and render it on a skirt
#   make test   install, run the test suite, then check the built wheel (what .ci/run calls)
PYTHON ?= python3
VENV   ?= .venv
BIN     = $(VENV)/bin
STAMP   = $(VENV)/.weavecap-installed

.PHONY: install demo test man fixtures bench

install: $(STAMP)

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	# torch first: the pinned CPU build is on disk; anything else would pull CUDA wheels.
	$(BIN)/python -m pip install -q torch==2.13.0
	$(BIN)/python -m pip install -q -e '.[test]'
	$(BIN)/weavecap doctor --check
	touch $(STAMP)

demo: install
	$(BIN)/weavecap fit fixtures/photos/twill_3_1.png -o out/twill_3_1 --force
	$(BIN)/weavecap synth out/twill_3_1/params.json -o out/twill_3_1/resynth.png --tiles 4x4 --size 512 --force
	# the captured fabric on a garment (a coarse 3 mm pitch, so the weave shows at this size)
	$(BIN)/weavecap render out/twill_3_1/params.json fixtures/meshes/skirt.obj -o out/twill_3_1/skirt.png \
	  --size 560x420 --view 20,12 --pitch-mm 3 --force

test: install
	$(BIN)/python -m pytest -q -p no:cacheprovider
	# the wheel as users install it: built, installed into a fresh venv, run outside the tree
	bash scripts/check_wheel.sh

man: install
	$(BIN)/python -m weavecap.cli.manpages man

# The fixtures' meshes and synthetic photos (committed; the command that made them, for every fixture)
fixtures: install
	$(BIN)/python fixtures/make_meshes.py
	mkdir -p fixtures/photos
	for f in fixtures/params/*.json; do \
	  $(BIN)/weavecap synth $$f -o fixtures/photos/$$(basename $$f .json).png --tiles 4x4 --size 512 --seed 0 --force; \
	done

# Performance figures of docs/performance.md (cold and warm renders, forward and backward, memory)
bench: install
	$(BIN)/weavecap bench
	$(BIN)/python scripts/measure_geometry.py
