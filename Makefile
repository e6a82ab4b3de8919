# contactlab: two commands on a fresh machine — `make demo` and `make test`.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
SEED   ?= 1

.PHONY: all env demo test fuzz bench reproduce clean

all: test

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip

$(STAMP): pyproject.toml | $(BIN)/python
	$(BIN)/pip install -q -e '.[test,bench]'
	touch $(STAMP)

env: $(STAMP)

## Run the main job end to end on simulated data and write a report under reports/:
## simulate the thesis's high-frequency training and test runs (7.3), train every model
## of the four-node feature graph, recognise the contact state of the test runs with the
## observer (6.4), report the archive with its results, then reproduce two experiments.
GRAPH := datasets_spec/graphs/hf-context-free.toml
demo: $(STAMP)
	@mkdir -p build/demo
	$(BIN)/contactlab acquire --spec hf-train --seed $(SEED) --out build/demo/hf-train.h5 --force
	$(BIN)/contactlab acquire --spec hf-test --seed $(SEED) --out build/demo/hf-test.h5 --force
	$(BIN)/contactlab validate build/demo/hf-test.h5
	$(BIN)/contactlab train build/demo/hf-train.h5 --graph $(GRAPH) --order 1 --mean --reduce mean --out build/demo/hf-models.h5 --force
	$(BIN)/contactlab recognize build/demo/hf-test.h5 --graph $(GRAPH) --models build/demo/hf-models.h5
	$(BIN)/contactlab report build/demo/hf-test.h5 --out reports/demo --force
	$(BIN)/contactlab reproduce ph-demo hf-recognition --out reports --seed $(SEED)
	@echo "demo report: reports/demo/index.html (experiments: reports/index.html)"

## Run the test suite.
test: $(STAMP)
	$(BIN)/python -m pytest

## Fuzz every reader of user files with many more random cases than `make test` runs
## (archives, CSV files, feature graphs, models files; a few minutes).
fuzz: $(STAMP)
	HYPOTHESIS_PROFILE=fuzz $(BIN)/python -m pytest tests/test_fuzz_inputs.py -p no:cacheprovider

## Benchmarks against the peers named in the issues (ratios printed, same run).
bench: $(STAMP)
	$(BIN)/python -m benchmarks

## Every thesis experiment that is implemented.
reproduce: $(STAMP)
	$(BIN)/contactlab reproduce --all --out reports --seed $(SEED)

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache
