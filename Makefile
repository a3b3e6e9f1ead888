# symbolic — common tasks. PYTHON may point at a virtualenv's interpreter.
PYTHON ?= python3
ROBOTS := fivebar puma560 panda janot_branch omni

.PHONY: install test test-fast generate check-generated bench clean

install:
	$(PYTHON) -m pip install -e '.[dev]'

test:
	$(PYTHON) -m pytest -n 2 -q

test-fast:
	$(PYTHON) -m pytest -n 2 -q -m "not slow"

# Regenerate generated/ from the built-in robots (byte-identical from run to run), docs/reproduction.md, and
# the bench/results/ sections that README.md and docs/*.md quote (bench/quotes.py).
generate:
	$(PYTHON) -m symbolic.builtin_outputs generated
	$(PYTHON) -m symbolic -q reproduce --markdown docs/reproduction.md
	$(PYTHON) bench/quotes.py

# Fails when the committed generated/ (or a generated part of docs/, README.md) differs from a fresh generation.
check-generated: generate
	@git diff --exit-code --stat -- generated/ docs/ README.md || (echo "generated/, docs/ or README.md is stale: run 'make generate' and commit" >&2; exit 1)
	@test -z "$$(git status --porcelain --untracked-files=all -- generated/)" || (git status --short -- generated/; echo "generated/ has untracked files: run 'make generate' and commit" >&2; exit 1)

bench:
	$(PYTHON) -m pip install --quiet -e '.[bench,fleet,bags]'
	$(PYTHON) bench/derivation.py --out bench/results/derivation.md
	$(PYTHON) bench/runtime.py --out bench/results/runtime.md
	$(PYTHON) bench/export.py --out bench/results/export.md
	$(PYTHON) bench/identification.py --out bench/results/identification.md
	$(PYTHON) bench/simulate.py --out bench/results/simulate.md
	$(PYTHON) bench/simulate_command.py --out bench/results/simulate_command.md
	$(PYTHON) bench/startup.py --out bench/results/startup.md
	$(PYTHON) bench/diagnose.py --out bench/results/diagnose.md
	$(PYTHON) bench/emps_resonance.py --out bench/results/emps_resonance.md
	$(PYTHON) bench/cache.py --out bench/results/cache.md
	$(PYTHON) bench/beams.py --out bench/results/beams.md
	$(PYTHON) bench/consistent.py --out bench/results/consistent.md
	$(PYTHON) bench/output_error.py --out bench/results/output_error.md
	$(PYTHON) bench/response.py --out bench/results/response.md
	$(PYTHON) bench/response.py --variety
	$(PYTHON) bench/joint_elasticity.py --out bench/results/joint_elasticity.md
	$(PYTHON) bench/unmeasured.py --out bench/results/unmeasured.md
	$(PYTHON) bench/fleet.py --out bench/results/fleet.md
	$(PYTHON) bench/float_accuracy.py --out bench/results/float_accuracy.md
	$(PYTHON) bench/bag_load.py --out bench/results/bag_load.md
	$(PYTHON) bench/excitation.py --out bench/results/excitation.md
	$(PYTHON) bench/quotes.py

clean:
	rm -rf build dist *.egg-info .pytest_cache .hypothesis
