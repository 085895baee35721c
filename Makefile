# RoboCal: `make demo` opens the wizard on the virtual lab, `make test` runs the suite,
# `make bench` prints measured figures beside their targets. Each bootstraps .venv itself.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: demo test bench check-libs clean

$(STAMP): pyproject.toml
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV) || { \
	  echo "Could not create $(VENV). On Debian/Ubuntu run: sudo apt-get install -y python3-venv"; exit 1; }
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -e ".[test]"
	@touch $(STAMP)

check-libs: $(STAMP)
	@$(BIN)/python packaging/check_qt_libs.py --platform $${QT_QPA_PLATFORM:-xcb}

demo: $(STAMP) check-libs
	$(BIN)/robocal gui --demo

test: $(STAMP)
	@QT_QPA_PLATFORM=offscreen $(BIN)/python packaging/check_qt_libs.py --platform offscreen
	QT_QPA_PLATFORM=offscreen $(BIN)/python -m pytest $(PYTEST_ARGS)

bench: $(STAMP)
	QT_QPA_PLATFORM=offscreen $(BIN)/python -m bench $(BENCH_ARGS)

clean:
	rm -rf $(VENV) build dist *.egg-info .pytest_cache
