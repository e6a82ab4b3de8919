# contactlab: two commands on a fresh machine — `make demo` and `make test`.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
SEED   ?= 1

.PHONY: all env demo test bench reproduce clean

all: test

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip

$(STAMP): pyproject.toml | $(BIN)/python
	$(BIN)/pip install -q -e '.[test,bench]'
	touch $(STAMP)

env: $(STAMP)

## Run the main job end to end on simulated data and write a report under reports/.
demo: $(STAMP)
	$(BIN)/contactlab reproduce ph-demo ph-roc --out reports --seed $(SEED)
	@echo "demo report: reports/index.html"

## Run the test suite.
test: $(STAMP)
	$(BIN)/python -m pytest

## Benchmarks against the peers named in the issues (ratios printed, same run).
bench: $(STAMP)
	$(BIN)/python -m benchmarks

## Every thesis experiment that is implemented.
reproduce: $(STAMP)
	$(BIN)/contactlab reproduce --all --out reports --seed $(SEED)

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache
