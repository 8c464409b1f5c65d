"""Sessions: `nox -s tests` (default), `lint`, `plugins`, `docs`.

Every session installs through constraints.txt so the versions are the tested ones, and torch
resolves to the pinned CPU build instead of gigabytes of CUDA packages.
"""

from __future__ import annotations

import os

import nox

nox.options.sessions = ["tests"]
nox.options.reuse_existing_virtualenvs = False

PYTHON = "3.11"
CONSTRAINTS = ("-c", "constraints.txt")
PLUGIN = "plugins/momu-plugin-example"
TEST_ENV = {
    "WANDB_MODE": "disabled",
    "HF_HUB_OFFLINE": "1",
    "HYPOTHESIS_PROFILE": "ci",
    "MOMU_REQUIRE_PLUGIN": "1",
    "OMP_NUM_THREADS": "1",
    "PYTHONHASHSEED": "0",
}


def _install(session: nox.Session, *extras: str, plugin: bool = False) -> None:
    spec = f".[{','.join(extras)}]" if extras else "."
    session.install(*CONSTRAINTS, "-e", spec)
    if plugin:
        session.install(*CONSTRAINTS, "--no-deps", "-e", PLUGIN)


@nox.session(python=PYTHON)
def tests(session: nox.Session) -> None:
    """Unit, property and integration tests, the example plugin's tests, and the smoke recipes."""
    _install(session, "test", "render", plugin=True)
    workers = os.environ.get("MOMU_TEST_WORKERS", "2")
    args = session.posargs or ["tests", f"{PLUGIN}/tests", "-n", workers, "--durations=15"]
    session.run("pytest", *args, env=TEST_ENV)


@nox.session(python=PYTHON)
def plugins(session: nox.Session) -> None:
    """Install the example plugin next to momu; run its tests and the core's plugin-discovery tests."""
    _install(session, "test", plugin=True)
    session.run(
        "pytest",
        f"{PLUGIN}/tests",
        "tests/unit/test_registry.py",
        "tests/integration/test_plugin_installed.py",
        *session.posargs,
        env=TEST_ENV,
    )


@nox.session(python=PYTHON)
def lint(session: nox.Session) -> None:
    """ruff (lint + format check) on everything, mypy on src/."""
    _install(session, "test", "lint")
    session.run("ruff", "check", "src", "tests", "plugins", "recipes", "benchmarks", "noxfile.py")
    session.run("ruff", "format", "--check", "src", "tests", "plugins", "recipes", "benchmarks", "noxfile.py")
    session.run("mypy", "src")


@nox.session(python=PYTHON)
def docs(session: nox.Session) -> None:
    """Build the documentation into site/ (fails on broken links or missing pages)."""
    session.install(*CONSTRAINTS, "mkdocs")
    session.run("mkdocs", "build", "--strict", "--site-dir", "site")
