# The README's two commands, on a fresh machine:
#
#   make run    # the main command: python -m agents.reproduce_paper (the paper's Table I)
#   make test   # ruff check . && ruff format --check . && python -m pytest
#
# Both set up what they need first, once: a virtualenv in .venv, the CPU build of torch (else
# pip fetches a multi-GB CUDA build), and the package, editable, with its [train,test,clients]
# extras.
# The set-up is redone only when pyproject.toml changes (a stamp file in .venv), so a second
# run starts at once. `make setup` does the set-up alone; `make run ARGS="--trials 30"` passes
# arguments to the main command; `make clean` removes .venv.
#
#   make docs   # the documentation site, docs/ -> docs/_build/html
#
# It adds the [docs] extra to the same .venv (its own stamp) and builds from scratch (-E, so
# every page's warnings show every time) with warnings as errors (-W --keep-going: all of them
# listed before it fails) and every cross-reference checked (-n). SPHINXOPTS adds options.
PYTHON ?= python3
VENV ?= .venv
EXTRAS ?= train,test,clients
ARGS ?=
comma := ,
TORCH := torch==2.13.0
TORCH_CPU_INDEX := https://download.pytorch.org/whl/cpu
STAMP := $(VENV)/.installed-$(subst $(comma),-,$(EXTRAS))
DOCS_STAMP := $(STAMP)-docs
BIN := $(VENV)/bin
SPHINXOPTS ?=

.PHONY: run test docs setup clean

run: $(STAMP)
	$(BIN)/python -m agents.reproduce_paper $(ARGS)

test: $(STAMP)
	. $(BIN)/activate && ruff check . && ruff format --check . && python -m pytest $(ARGS)

docs: $(DOCS_STAMP)
	$(BIN)/python -m sphinx -b html -E -W --keep-going -n -q $(SPHINXOPTS) docs docs/_build/html
	@echo "built docs/_build/html/index.html"

setup: $(STAMP)

# The CPU index first, without retries (where it cannot be reached, as behind a proxy or
# with a local index only, pip fails in seconds), then whatever index pip is configured with.
# Each stage prints one line as it starts and one with its time as it ends (pip itself is
# quiet: its progress bars would bury the rest).
$(STAMP): pyproject.toml
	@echo "set-up 1/3: a virtualenv in $(VENV)"
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	@echo "set-up 2/3: $(TORCH), the CPU build (about 200 MB the first time)"; start=$$(date +%s); \
		{ $(BIN)/python -m pip install --quiet --retries 0 --timeout 15 $(TORCH) \
		--index-url $(TORCH_CPU_INDEX) \
		|| $(BIN)/python -m pip install --quiet $(TORCH); } && \
		echo "  took $$(( $$(date +%s) - start )) s"
	@echo "set-up 3/3: the package, editable, with [$(EXTRAS)]"; start=$$(date +%s); \
		$(BIN)/python -m pip install --quiet -e ".[$(EXTRAS)]" && \
		echo "  took $$(( $$(date +%s) - start )) s"
	@touch $@

$(DOCS_STAMP): $(STAMP)
	@echo "set-up: the [docs] extra"; start=$$(date +%s); \
		$(BIN)/python -m pip install --quiet -e ".[$(EXTRAS),docs]" && \
		echo "  took $$(( $$(date +%s) - start )) s"
	@touch $@

clean:
	rm -rf $(VENV)
