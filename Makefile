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

## Run the main job end to end on simulated data and write a report under reports/:
## simulate a small stroking dataset, report it, then reproduce the experiments.
demo: $(STAMP)
	@mkdir -p build/demo
	$(BIN)/contactlab acquire --spec stroke-a --trials 2 --seed $(SEED) --out build/demo/stroke-a.h5 --force
	$(BIN)/contactlab validate build/demo/stroke-a.h5
	$(BIN)/contactlab report build/demo/stroke-a.h5 --out reports/stroke-a
	$(BIN)/contactlab reproduce ph-demo ph-roc datasets --out reports --seed $(SEED)
	@echo "demo report: reports/index.html (dataset report: reports/stroke-a/index.html)"

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
