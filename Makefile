# Two entry points: `make run` and `make test`. Both install what is missing first.
# The system package list lives in packaging/apt-packages.txt (the Dockerfile reads the same file);
# packaging/apt-packages-test.txt adds what only the tests need (Chromium renders the HTML report).
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
APT_PACKAGES := $(shell cat packaging/apt-packages.txt)
APT_TEST_PACKAGES := $(shell cat packaging/apt-packages-test.txt)
STAMP := $(VENV)/.legplan-installed
OUT ?= outputs

.PHONY: run test install system-packages test-system-packages clean

# nav_30m and compare_baselines run their independent stages two at a time (--jobs 2).
run: install
	$(VENV)/bin/legplan --version
	$(VENV)/bin/legplan pipeline run pipelines/gap_crossing.yaml -o $(OUT)/gap_crossing
	$(VENV)/bin/legplan pipeline run pipelines/nav_30m.yaml -o $(OUT)/nav_30m --jobs 2
	$(VENV)/bin/legplan pipeline run pipelines/compare_baselines.yaml -o $(OUT)/compare_baselines --jobs 2
	$(VENV)/bin/legplan pipeline run pipelines/pallet_climb.yaml -o $(OUT)/pallet_climb
	@echo "reports: $(OUT)/{gap_crossing,nav_30m,compare_baselines,pallet_climb}/report/index.html"

# The suite runs on every core (pytest-xdist); work stealing keeps the long end-to-end tests from
# leaving a worker idle at the end.
test: install test-system-packages
	$(PY) -m pytest -q -n auto --dist worksteal

install: $(STAMP)

# dpkg -s answers in milliseconds when everything is there, so apt-get runs only on a new machine.
apt_install = dpkg -s $(1) >/dev/null 2>&1 || { \
  echo "installing system packages: $(1)"; \
  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $(1); }

system-packages:
	@$(call apt_install,$(APT_PACKAGES))

test-system-packages:
	@$(call apt_install,$(APT_TEST_PACKAGES))

$(STAMP): pyproject.toml packaging/apt-packages.txt
	@$(MAKE) --no-print-directory system-packages
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[test]'
	@touch $(STAMP)

clean:
	rm -rf $(VENV) build *.egg-info
