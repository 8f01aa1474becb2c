# Two commands do everything on a fresh Debian machine: `make demo` and `make test`.
.PHONY: demo test setup bench clean

setup:
	@bash scripts/setup.sh

demo: setup
	.venv/bin/python scripts/demo.py demo-output

test: setup
	.venv/bin/python -m pytest $(PYTEST_ARGS)

bench: setup
	.venv/bin/python benchmarks/bench_core.py

clean:
	rm -rf demo-output .pytest_cache .hypothesis
