# Set-up and everyday commands. `make demo` and `make test` are the README's two commands.
PYTHON ?= python3.11
VENV ?= .venv
PY := $(VENV)/bin/python
PIP := $(PY) -m pip

.PHONY: setup demo test lint bench clean

$(VENV)/.installed: pyproject.toml constraints.txt
	$(PYTHON) -m venv $(VENV)
	$(PIP) install -q --upgrade pip
	$(PIP) install -q -c constraints.txt torch==2.13.0
	$(PIP) install -q -c constraints.txt -e '.[dev,compat,postgres,s3]'
	touch $@

setup: $(VENV)/.installed

demo: setup
	bash examples/quickstart.sh

test: setup
	bash tools/test_deps.sh
	$(PY) -m pytest -q -rs

lint: setup
	$(VENV)/bin/ruff check drx tests tools benchmarks examples
	$(PY) -m mypy
	$(VENV)/bin/lint-imports

bench: setup
	$(PY) benchmarks/sim_throughput.py

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache
