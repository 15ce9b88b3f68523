# The two quick-start commands: `make demo` and `make test`. Both install into .venv first.
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-stamp

.PHONY: demo test bench install browser clean

$(STAMP): pyproject.toml constraints.txt
	python3 -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -c constraints.txt -e ".[test]"
	touch $@

install: $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/geostructure demo -o out/demo

browser:
	bash scripts/install-browser.sh

test: $(STAMP) browser
	$(PY) -m pytest

bench: $(STAMP)
	$(PY) -m pip install -q -c constraints.txt -e ".[open3d]"
	$(PY) bench/bench_pipeline.py

clean:
	rm -rf $(VENV) out
