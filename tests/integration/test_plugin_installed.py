"""The installed example plugin, seen through momu's public surface (`momu list`, configs).

nox's `tests` and `plugins` sessions install the plugin and set MOMU_REQUIRE_PLUGIN=1, so there
these tests fail, rather than skip, when the plugin path is broken.
"""

from __future__ import annotations

import os
import subprocess
import sys
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import pytest

from momu.config import build_component, load_config


@pytest.fixture(scope="module")
def plugin_version() -> str:
    try:
        return version("momu-plugin-example")
    except PackageNotFoundError:
        if os.environ.get("MOMU_REQUIRE_PLUGIN") == "1":
            pytest.fail("momu-plugin-example is not installed but MOMU_REQUIRE_PLUGIN=1")
        pytest.skip("momu-plugin-example not installed")


def _momu(*args: str) -> subprocess.CompletedProcess[str]:
    script = Path(sys.executable).with_name("momu")
    command = [str(script)] if script.exists() else [sys.executable, "-m", "momu"]
    return subprocess.run([*command, *args], capture_output=True, text=True, check=False)


def test_momu_list_shows_plugin_parts_with_source(plugin_version: str) -> None:
    proc = _momu("list")
    assert proc.returncode == 0, proc.stderr
    rows = {line.split()[0]: line.split()[-1] for line in proc.stdout.splitlines() if line.startswith("  ")}
    assert rows["residual_mlp"] == f"momu-plugin-example=={plugin_version}"
    assert rows["motion_jerk"] == f"momu-plugin-example=={plugin_version}"


def test_plugin_backbone_usable_by_name_in_config(tmp_path: Path, plugin_version: str) -> None:
    path = tmp_path / "run.yaml"
    path.write_text("backbone:\n  name: residual_mlp\n  in_channels: 4\n")
    proc = _momu("config", "show", str(path), "backbone.hidden=16")
    assert proc.returncode == 0, proc.stderr
    assert "hidden: 16" in proc.stdout and "in_channels: 4" in proc.stdout
    bad = _momu("config", "show", str(path), "backbone.hiden=16")
    assert bad.returncode == 2 and "valid keys: in_channels, cond_channels, hidden, depth" in bad.stderr
    net = build_component(load_config(path).backbone, "backbones")
    assert net.in_channels == 4
