# Two commands on a fresh clone: `make demo` and `make test` (ruff, the docs site, the tests but the
# slow ones). Each builds .venv itself. `make test-slow` runs the slow tests (the browser ones and
# the long cases; CI runs both), `make docs` builds the site alone, `make bench` runs the benchmarks.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: demo test test-slow docs gallery bench lint clean

$(STAMP): pyproject.toml
	$(PYTHON) -c 'import sys; assert sys.version_info >= (3, 11), "robocal needs Python >= 3.11"'
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test,docs]'
	touch $@

demo: $(STAMP)
	$(VENV)/bin/robocal demo

# pytest's addopts leave out the tests marked slow (pyproject.toml): under 10 minutes on a busy
# 2-core machine
test: $(STAMP)
	$(PY) -m ruff check .
	$(MAKE) --no-print-directory docs
	$(PY) -m pytest -q

# only the tests marked slow: the browser tests (headless Chromium; where it cannot be installed they
# skip) and the long cases
test-slow: $(STAMP)
	@command -v chromium >/dev/null 2>&1 || command -v chromium-browser >/dev/null 2>&1 || \
	  { command -v apt-get >/dev/null 2>&1 && \
	    (apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get install -y -q chromium) >/dev/null 2>&1; } || \
	  echo "chromium not installed (no apt-get or no permission): the browser tests will be skipped"
	$(PY) -m pytest -q -m slow

# the documentation site in build/site; --strict: any warning (a broken link, a missing page) fails
docs: gallery
	@# not --quiet: mkdocs then drops the warnings that --strict counts
	NO_MKDOCS_2_WARNING=1 $(PY) -m mkdocs build --strict

# the gallery's examples (examples/gallery) whose outputs build/gallery has not cached for their
# current text: run once here (~30 s for all), read by the site build (scripts/docs_gallery.py)
gallery: $(STAMP)
	$(PY) scripts/docs_gallery.py

bench: $(STAMP)
	$(PY) -m pip install --quiet -e '.[bench]'
	@# pybotics (a peer in bench_calibrate) pins numpy < 2 but runs on numpy 2: install it alone
	$(PY) -m pip install --quiet --no-deps pybotics || echo "pybotics not installed: its row is skipped"
	@# FIGAROH (the peer of bench_peers) brings pinocchio and its own stack: optional, like its data
	$(PY) -m pip install --quiet -e '.[peers]' || echo "figaroh not installed: bench_peers' FIGAROH rows are skipped"
	$(PY) benchmarks/run.py

lint: $(STAMP)
	$(PY) -m ruff check .

clean:
	rm -rf $(VENV) build src/*.egg-info
