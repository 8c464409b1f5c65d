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


_REPRODUCE_MARKER = "<!-- written by `nox -s reproduce`; a README without this line is kept -->"


def _reproduction_readme(table: str, result: dict, command: str) -> str:
    """reproductions/<table>/README.md: how it was produced, cost, and how to compare it with the paper."""
    prov = result["provenance"]
    lines = [
        f"# {result['title']}",
        "",
        f"Produced by `nox -s reproduce` with `{command}`",
        f"(preset `{result['preset']}`, data `{result['data']}`, seeds {result['seeds']}).",
        "",
        f"- wall time: {prov['wall_time_s']:.0f} s on {prov['num_processes']} process(es), "
        f"device {prov['device']}",
        f"- peak memory (main process): {prov['peak_memory_mib']:.0f} MiB",
        f"- commit: `{prov['git_commit']}`",
        "",
        "`results.md` holds our numbers beside the paper's and the calibration rows; `results.json`",
        "the same with the resolved config and provenance. The synthetic data stand in for the",
        "paper's datasets, so compare the *ordering* of rows and our row against the calibration",
        "rows, not the absolute values.",
        "",
        "## Our rows against the calibration rows",
        "",
    ]
    cal = {c["name"]: c["metrics"] for c in result["calibration"]}
    shuffled = next((m for n, m in cal.items() if "shuffled" in n), {})
    for row in result["rows"]:
        verdicts = []
        for col in result["columns"]:
            ours, chance = row["metrics"].get(col["key"]), shuffled.get(col["key"])
            if ours is None or chance is None:
                continue
            better = ours > chance if col["higher_is_better"] else ours < chance
            verb = "ties" if ours == chance else ("beats" if better else "does not beat")
            verdicts.append(f"{col['label']} {verb} shuffled ({ours:.3g} vs {chance:.3g})")
        lines.append(f"- {row['id']} {row['name']}: " + ("; ".join(verdicts) or "no comparable cells"))
    lines += _reproduction_ordering(result)
    return "\n".join(lines) + "\n"


def _reproduction_ordering(result: dict) -> list[str]:
    """Per column, the share of row pairs our numbers order as the paper's do (tables with 2+ rows)."""
    rows = [r for r in result["rows"] if r["paper"]]
    if len(rows) < 2:
        return []
    lines = ["", "## Ordering of rows against the paper's", ""]
    for col in result["columns"]:
        key, sign = col["key"], 1.0 if col["higher_is_better"] else -1.0
        cells = [(r["id"], r["metrics"].get(key), r["paper"].get(key)) for r in rows]
        cells = [c for c in cells if c[1] is not None and c[2] is not None]
        pairs = [(a, b) for i, a in enumerate(cells) for b in cells[i + 1 :] if a[2] != b[2]]
        if not pairs:
            continue
        agree = sum((a[1] - b[1]) * (a[2] - b[2]) > 0 for a, b in pairs)
        best_ours = max(cells, key=lambda c: sign * c[1])[0]
        best_paper = max(cells, key=lambda c: sign * c[2])[0]
        lines.append(
            f"- {col['label']}: {agree}/{len(pairs)} row pairs ordered as in the paper; "
            f"best row {best_ours} here, {best_paper} in the paper (ties count as disagreement)"
        )
    return lines


@nox.session(python=PYTHON, default=False)
def reproduce(session: nox.Session) -> None:
    """Regenerate reproductions/<table>/ for every MoMu recipe at the `cpu` preset on synthetic data.

    Non-default (hours on a 2-core CPU). `nox -s reproduce -- momu_table2 momu_table5` runs a subset.
    Every recipe writes into one work folder (outputs/reproduce/, git-ignored), so shared
    stages are trained once; results.json/results.md/config.yaml and the plots are copied to
    reproductions/<table>/ with a README per table.
    """
    import json
    import shutil
    from pathlib import Path

    _install(session, "render")
    unknown = [r for r in session.posargs if r not in MOMU_RECIPES]
    if unknown:
        session.error(f"unknown recipe(s) {', '.join(unknown)}; valid: {', '.join(MOMU_RECIPES)}")
    work = Path("outputs") / "reproduce"
    env = {"WANDB_MODE": "disabled", "HF_HUB_OFFLINE": "1", "PYTHONHASHSEED": "0"}
    for table in session.posargs or MOMU_RECIPES:
        args = [f"recipes/{table}.py", "--preset", "cpu", "--data", "synth", "--out", str(work)]
        args += ["--tracker", "none"]
        session.run("python", *args, env=env)
        src, dst = work / table, Path("reproductions") / table
        dst.mkdir(parents=True, exist_ok=True)
        for path in src.iterdir():
            if path.is_file() and path.suffix in {".json", ".md", ".yaml", ".png"}:
                shutil.copy2(path, dst / path.name)
        for plot in sorted((src / "models").glob("*/beats.png")):
            shutil.copy2(plot, dst / f"beats-{plot.parent.name}.png")
        result = json.loads((src / "results.json").read_text())
        command = "python " + " ".join(args)
        text = _REPRODUCE_MARKER + "\n" + _reproduction_readme(table, result, command)
        readme = dst / "README.md"
        if readme.is_file() and not readme.read_text().startswith(_REPRODUCE_MARKER):
            readme = dst / "REPRODUCE.md"  # keep a hand-written README; put the summary beside it
            session.warn(f"{dst / 'README.md'} is hand-written: kept; summary in {readme}, check its numbers")
        readme.write_text(text)
        session.log(f"{table}: {dst}")
