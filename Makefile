# Two commands on a fresh clone: `make demo` and `make test` (ruff, the docs site, the tests).
# Each builds .venv itself. `make docs` builds the site alone, `make bench` runs the benchmarks.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: demo test docs bench lint clean

$(STAMP): pyproject.toml
	$(PYTHON) -c 'import sys; assert sys.version_info >= (3, 11), "robocal needs Python >= 3.11"'
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test,docs]'
	touch $@

demo: $(STAMP)
	$(VENV)/bin/robocal demo

test: $(STAMP)
	@# headless Chromium for tests/test_browser.py; where it cannot be installed that test skips
	@command -v chromium >/dev/null 2>&1 || command -v chromium-browser >/dev/null 2>&1 || \
	  { command -v apt-get >/dev/null 2>&1 && \
	    (apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get install -y -q chromium) >/dev/null 2>&1; } || \
	  echo "chromium not installed (no apt-get or no permission): the browser test will be skipped"
	$(PY) -m ruff check .
	$(MAKE) --no-print-directory docs
	$(PY) -m pytest -q

# the documentation site in build/site; --strict: any warning (a broken link, a missing page) fails
docs: $(STAMP)
	@# not --quiet: mkdocs then drops the warnings that --strict counts
	NO_MKDOCS_2_WARNING=1 $(PY) -m mkdocs build --strict

bench: $(STAMP)
	$(PY) -m pip install --quiet -e '.[bench]'
	@# pybotics (a peer in bench_calibrate) pins numpy < 2 but runs on numpy 2: install it alone
	$(PY) -m pip install --quiet --no-deps pybotics || echo "pybotics not installed: its row is skipped"
	$(PY) benchmarks/run.py

lint: $(STAMP)
	$(PY) -m ruff check .

clean:
	rm -rf $(VENV) build src/*.egg-info
