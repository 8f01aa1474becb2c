# Two commands do everything on a fresh Debian machine: `make demo` and `make test`.
.PHONY: demo test test-fast setup lock bench clean

setup:
	@bash scripts/setup.sh

# Bring uv.lock into line with pyproject.toml after a change to the dependencies (commit both
# together); `make lock LOCK_ARGS=--upgrade` moves every package to its newest allowed release.
lock:
	@bash scripts/setup.sh --lock $(LOCK_ARGS)

demo: setup
	.venv/bin/python scripts/demo.py demo-output

# Two workers (the machine's two cores); a file's tests stay on one worker, so its module-scoped
# set-ups (a server, a browser, a conversion) are made once. A worker that crashes ends the run at
# once, naming the test it ran: pytest-xdist 3.8 can wait forever for a replacement worker under
# --dist loadfile (pytest-xdist issue 1323).
PARALLEL ?= -n 2 --dist loadfile --max-worker-restart 0

test: setup
	.venv/bin/python -m pytest $(PARALLEL) $(PYTEST_ARGS)

bench: setup
	.venv/bin/python benchmarks/bench_core.py

clean:
	rm -rf demo-output .pytest_cache .hypothesis

# The developer's loop: everything but the slow tiers (browser, slicer, real microscope files,
# napari, slow), with few hypothesis examples (docs/testing.md).
test-fast: setup
	TAMP_HYPOTHESIS=dev .venv/bin/python -m pytest $(PARALLEL) -m "not slow and not browser and not slicer and not real and not napari" $(PYTEST_ARGS)
