# The two quick-start commands: `make demo` and `make test`. Both install into .venv first.
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-stamp

.PHONY: demo test lint bench install system-deps clean

# Two installs into one .venv: the package alone (what measure, sets, kinematics, report and
# the demo need) for `make demo`, and every extra (tests, video/photo reconstruction, Dask)
# for `make test`. BASE is the first, STAMP the second.
BASE := $(VENV)/.base-stamp

$(BASE): pyproject.toml constraints.txt
	python3 -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -c constraints.txt -e .
	touch $@

$(STAMP): $(BASE)
	$(PY) -m pip install -q -c constraints.txt -e ".[test,reconstruct,dask]"
	touch $@

install: $(STAMP)

demo: $(BASE)
	$(VENV)/bin/geostructure demo -o out/demo

# Debian packages the tests use (Chromium, ChromeDriver, GDAL, CloudCompare, xvfb, libGL):
# installed with apt-get when run as root, and said before; skipped with a note otherwise.
system-deps:
	bash scripts/install-system-deps.sh

test: $(STAMP) system-deps lint
	$(PY) -m pytest

lint: $(STAMP)
	$(VENV)/bin/ruff check src tests bench
	$(VENV)/bin/ruff format --check src tests bench
	$(VENV)/bin/mypy

bench: $(STAMP) system-deps
	$(PY) bench/bench_pipeline.py

clean:
	rm -rf $(VENV) out
