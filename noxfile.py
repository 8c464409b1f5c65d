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
    _install(session, "test", "render", "video", plugin=True)
    workers = os.environ.get("MOMU_TEST_WORKERS", "2")
    # --timeout turns a hung test (a deadlocked process group, say) into a failure with a traceback.
    args = session.posargs or ["tests", f"{PLUGIN}/tests", "-n", workers, "--durations=25", "--timeout=900"]
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


MOMU_RECIPES = (
    "momu_table2",
    "momu_table3",
    "momu_table4",
    "momu_table5",
    "momu_table6",
    "momu_table7",
    "momu_table10",
)
"""Every MoMu-Diffusion recipe, in the order `reproduce` runs them (Tables 5–6 reuse Table 2's model)."""

MOFUSION_RECIPES = (
    "mofusion_table1",
    "mofusion_supp_table1",
    "mofusion_supp_table2",
    "mofusion_table2",
)
"""Every MoFusion recipe, in run order (supp. Table 2 reuses supp. Table 1's models)."""
HARMOGAN_RECIPES = ("harmogan_table1", "harmogan_table2", "harmogan_fig12", "harmogan_fig9", "harmogan_fig11")
"""Every HarmoGAN recipe, in the order `reproduce` runs them (all share <work>/harmogan_shared)."""
HARMOGAN_DATA = os.environ.get("MOMU_DWM_ROOT", "../shared/data/dance_with_melody")
"""The real Dance with Melody subset HarmoGAN's reproductions train on (`MOMU_DWM_ROOT` overrides)."""

RECIPES = MOMU_RECIPES + MOFUSION_RECIPES + HARMOGAN_RECIPES
JOBS = os.environ.get("MOMU_REPRODUCE_JOBS", "2")
"""Single-thread row/seed workers of `reproduce` (`--jobs`; the numbers do not depend on it)."""


@nox.session(python=PYTHON, default=False)
def reproduce(session: nox.Session) -> None:
    """Regenerate reproductions/<table>/ of every recipe at the `cpu` preset: MoMu and MoFusion on
    synthetic data, HarmoGAN on the real Dance with Melody subset (`MOMU_DWM_ROOT`, default
    ../shared/data/dance_with_melody).

    Non-default (hours on a 2-core CPU). `nox -s reproduce -- momu_table2 momu_table5` runs a subset.
    Every recipe writes into one work folder (outputs/reproduce/, git-ignored), so shared
    stages are trained once; results.json/results.md/config.yaml and the plots are copied to
    reproductions/<table>/ with a README per table.
    """
    from pathlib import Path

    _install(session, "render")
    unknown = [r for r in session.posargs if r not in RECIPES]
    if unknown:
        session.error(f"unknown recipe(s) {', '.join(unknown)}; valid: {', '.join(RECIPES)}")
    work = Path("outputs") / "reproduce"
    env = {"WANDB_MODE": "disabled", "HF_HUB_OFFLINE": "1", "PYTHONHASHSEED": "0"}
    for table in session.posargs or RECIPES:
        data = HARMOGAN_DATA if table in HARMOGAN_RECIPES else "synth"  # HarmoGAN trains on the real subset
        args = [f"recipes/{table}.py", "--preset", "cpu", "--data", data, "--out", str(work)]
        args += ["--tracker", "none", "--jobs", JOBS]  # 3 seeds (the cpu preset's default), rows in parallel
        session.run("python", *args, env=env)
        command = "python " + " ".join(args)
        dst = str(Path("reproductions") / table)
        session.run("python", "-m", "momu.engine.reproduce", str(work / table), dst, "--command", command)


@nox.session(python=PYTHON, default=False)
def pretrain(session: nox.Session) -> None:
    """Train the model shipped in src/momu/pretrained/ and check it on held-out real songs.

    Non-default: `momu train momu` on synth_dance (dwm21, cpu preset, seed 0), then the held-out
    Dance with Melody evaluation where ../shared/data is present (recipes/pretrain.py).
    """
    _install(session, "render")
    env = {"WANDB_MODE": "disabled", "HF_HUB_OFFLINE": "1", "PYTHONHASHSEED": "0"}
    session.run("python", "recipes/pretrain.py", *session.posargs, env=env)
