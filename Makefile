# RoboCal: `make demo` opens the wizard on the virtual lab, `make test` runs the suite,
# `make bench` prints measured figures beside their targets. Each bootstraps .venv itself.
# `make package` builds the desktop bundle dist/robocal/ (PyInstaller), `make package-check` runs
# it as a user would, `make install-desktop` adds its menu entry and icon under ~/.local/share.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: demo test test-quick bench check-libs clean package package-check install-desktop

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

# The suite runs on one worker per core and one more (pytest-xdist): its tests wait on robot
# simulators, pseudo-terminals and timers for about a tenth of their time, and the extra worker
# computes meanwhile (a 2-core machine: 231-242 s with 3 workers, 237-259 s with 2, the cores
# idle 25-28 core-seconds a run with 2). Each test module runs on one worker so its module-scoped
# fixtures are built once, the longest modules first (tests/scheduling.py);
# `make test PYTEST_ARGS="tests/core -x"` runs a part in one process. `make test-quick` leaves out
# the tests marked slow (over ~20 s each: demo walks, fuzzing, command chains on rendered images).
# The suite writes Python's bytecode caches even where the shell says not to
# (PYTHONDONTWRITEBYTECODE): pytest keeps each test module's rewritten asserts there, and every
# worker and every `robocal` process the tests start would otherwise compile the sources again
# (collection: 24 s per worker without them, 5 s with them).
TEST_WORKERS ?= $(shell echo $$(( $$(nproc 2>/dev/null || getconf _NPROCESSORS_ONLN) + 1 )))
PYTEST_ARGS ?= -n $(TEST_WORKERS) --dist loadscope
PYTEST := QT_QPA_PLATFORM=offscreen PYTHONDONTWRITEBYTECODE= $(BIN)/python -m pytest

test: $(STAMP)
	@QT_QPA_PLATFORM=offscreen $(BIN)/python packaging/check_qt_libs.py --platform offscreen
	$(PYTEST) $(PYTEST_ARGS)

test-quick: $(STAMP)
	$(PYTEST) $(PYTEST_ARGS) -m "not slow"

bench: $(STAMP)
	QT_QPA_PLATFORM=offscreen $(BIN)/python -m bench $(BENCH_ARGS)

DIST     := dist/robocal
DATA_DIR ?= $(HOME)/.local/share

package: $(STAMP)
	@$(BIN)/python -c "import PyInstaller" 2>/dev/null || $(BIN)/python -m pip install -q "pyinstaller>=6.10"
	$(BIN)/python -m PyInstaller packaging/robocal.spec --noconfirm --clean --log-level WARN \
	  --distpath dist --workpath build/pyinstaller

package-check:
	@test -x $(DIST)/robocal || { echo "No bundle in $(DIST): run make package first."; exit 1; }
	env -u PYTHONPATH -u VIRTUAL_ENV -u PYTHONHOME python3 packaging/check_bundle.py $(DIST)

install-desktop:
	@test -x $(DIST)/robocal || { echo "No bundle in $(DIST): run make package first."; exit 1; }
	install -d $(DATA_DIR)/applications $(DATA_DIR)/icons/hicolor/scalable/apps
	install -m 644 resources/icons/robocal.svg $(DATA_DIR)/icons/hicolor/scalable/apps/robocal.svg
	sed -e 's|^Exec=robocal|Exec=$(abspath $(DIST))/robocal|' -e 's|^TryExec=robocal|TryExec=$(abspath $(DIST))/robocal|' \
	  packaging/robocal.desktop > $(DATA_DIR)/applications/robocal.desktop
	@echo "Installed $(DATA_DIR)/applications/robocal.desktop (runs $(abspath $(DIST))/robocal)."

clean:
	rm -rf $(VENV) build dist *.egg-info .pytest_cache
