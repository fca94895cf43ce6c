"""The Dockerfile installs exactly what the Makefile installs (no Docker engine here to build it)."""

import re
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_dockerfile_and_makefile_share_the_package_list_and_pip_line():
    dockerfile = (ROOT / "Dockerfile").read_text()
    makefile = (ROOT / "Makefile").read_text()
    assert "APT_PACKAGES := $(shell cat packaging/apt-packages.txt)" in makefile
    assert "apt-get install -y -qq $(cat packaging/apt-packages.txt)" in dockerfile
    pip_line = "-m pip install -q -e '.[test]'"
    assert pip_line in makefile and pip_line in dockerfile
    assert re.search(r"^FROM python:3\.11-slim", dockerfile, re.M)
    assert re.search(r'^ENTRYPOINT \["legplan"\]', dockerfile, re.M)


def test_test_only_packages_stay_out_of_the_image():
    makefile = (ROOT / "Makefile").read_text()
    assert "test: install test-system-packages" in makefile
    assert "apt-packages-test.txt" not in (ROOT / "Dockerfile").read_text()


def test_package_list_has_suitesparse_and_build_tools():
    packages = (ROOT / "packaging/apt-packages.txt").read_text().split()
    assert {"libsuitesparse-dev", "build-essential"} <= set(packages)


def test_runtime_dependencies_are_pinned():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    names = {re.split("==", dep)[0].lower() for dep in project["dependencies"]}
    assert {"numpy", "scipy", "scikit-sparse", "pin", "python-fcl", "click", "h5py", "ompl"} <= names
    assert all("==" in dep for dep in project["dependencies"])
    assert project["scripts"]["legplan"] == "legplan.cli.main:cli"
