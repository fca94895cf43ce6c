"""The Dockerfile installs exactly what the Makefile installs (no Docker engine here to build it)."""

import json
import re
import shlex
import tomllib
from pathlib import Path

from packaging.specifiers import SpecifierSet

ROOT = Path(__file__).resolve().parents[1]


def dockerfile_instructions(text: str) -> list[tuple[str, str]]:
    """(INSTRUCTION, arguments) of a Dockerfile, continuation lines joined, comments dropped."""
    joined = re.sub(r"\\\n", " ", "\n".join(line for line in text.splitlines() if not line.lstrip().startswith("#")))
    return [(word.upper(), rest.strip()) for word, _, rest in (line.strip().partition(" ") for line in joined.splitlines())
            if word]


def shell_commands(script: str) -> list[list[str]]:
    """The commands of a `a && b && c` shell line, each split into words."""
    return [shlex.split(part) for part in script.split("&&") if part.strip()]


def makefile_recipe(text: str, target: str) -> list[str]:
    """The recipe lines (tab-indented, without a leading @) of the rule whose targets start with `target`."""
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(f"{target}:"))
    recipe = []
    for line in lines[start + 1:]:
        if not line.startswith("\t"):
            break
        recipe.append(line[1:].lstrip("@"))
    return recipe


def stages(dockerfile: list[tuple[str, str]]) -> list[list[tuple[str, str]]]:
    """The instructions of each FROM stage, in order."""
    out = []
    for word, args in dockerfile:
        if word == "FROM":
            out.append([])
        out[-1].append((word, args))
    return out


def test_dockerfile_installs_what_the_makefile_installs():
    """Parsed, not string-matched: the build stage installs the same apt package file and runs the
    same pip commands in the same order (into its venv, the project without its test extras and not
    editable); both stages start from a Python base image the project accepts; the `legplan`
    script is the entry point."""
    dockerfile = dockerfile_instructions((ROOT / "Dockerfile").read_text())
    build, runtime = stages(dockerfile)
    makefile = (ROOT / "Makefile").read_text()
    variables = dict(re.findall(r"^(\w+) := (.*)$", makefile, re.M))
    apt_file = re.fullmatch(r"\$\(shell cat (\S+)\)", variables["APT_PACKAGES"]).group(1)
    assert "$(call apt_install,$(APT_PACKAGES))" in makefile_recipe(makefile, "system-packages")
    runs = [command for word, args in build if word == "RUN" for command in shell_commands(args)]
    installs = [c for c in runs if c[:2] == ["apt-get", "install"] or c[1:3] == ["apt-get", "install"]]
    assert len(installs) == 1 and installs[0][-2:] == ["$(cat", f"{apt_file})"]
    copied = [args.split() for word, args in build if word == "COPY"]
    assert copied.index([apt_file, apt_file]) < [w for w, _ in build].index("RUN")   # copied before use
    docker_pip = [c[1:] for c in runs if c[0].endswith("python") and c[1:3] == ["-m", "pip"]]
    make_pip = [shlex.split(line)[1:] for line in makefile_recipe(makefile, "$(STAMP)")
                if line.startswith("$(PY) -m pip")]
    assert ["-m", "pip", "install", "-q", "-e", ".[test]"] in make_pip
    assert docker_pip == [["." if word == ".[test]" else word for word in c if word != "-e"] for c in make_pip]
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    for stage in (build, runtime):
        version = re.fullmatch(r"python:(\d+\.\d+)-slim(-\w+)?( AS \w+)?", stage[0][1]).group(1)
        assert SpecifierSet(project["requires-python"]).contains(version)
    assert build[0][1].split()[0] == runtime[0][1].split()[0]  # the venv's Python is the runtime's
    entry = json.loads(next(args for word, args in runtime if word == "ENTRYPOINT"))
    assert entry == ["legplan"] and "legplan" in project["scripts"]


def test_runtime_stage_is_slim_and_runs_as_a_user():
    """The runtime stage gets the build's venv only: no build tools, no test packages, no pip
    cache; it runs as a non-root user, and README shows `docker run --user`."""
    build, runtime = stages(dockerfile_instructions((ROOT / "Dockerfile").read_text()))
    text = " ".join(args for _, args in runtime)
    assert "apt-packages.txt" not in text and "pip install" not in text
    assert ["--from=build", "/opt/venv", "/opt/venv"] in [args.split() for word, args in runtime if word == "COPY"]
    assert ("ENV", "PIP_NO_CACHE_DIR=1") in build
    users = [args for word, args in runtime if word == "USER"]
    assert users and users[-1] not in ("root", "0")
    runtime_packages = (ROOT / "packaging/apt-packages-runtime.txt").read_text().split()
    assert runtime_packages and not set(runtime_packages) & {"build-essential", "python3-dev", "libsuitesparse-dev"}
    assert 'docker run --rm --user "$(id -u):$(id -g)"' in (ROOT / "README.md").read_text()


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
    assert project["scripts"]["legplan"] == "legplan.cli.main:main"
