# The two commands a newcomer runs (see README): `make demo` and `make test`.
# Both set up everything they need and are safe to run again.
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-stamp
DEMO_OUT ?= out/demo

.PHONY: demo test venv debian-deps clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip "setuptools>=77" wheel
	$(BIN)/python -m pip install -q -e '.[test]'
	touch $(STAMP)

venv: $(STAMP)

debian-deps:
	bash scripts/install-debian-deps.sh

demo: $(STAMP)
	bash scripts/demo.sh $(DEMO_OUT)

test: $(STAMP) debian-deps
	$(BIN)/python -m pytest -q $(PYTEST_ARGS)

clean:
	rm -rf $(VENV) out build *.egg-info
