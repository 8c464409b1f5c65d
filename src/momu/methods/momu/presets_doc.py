"""``docs/presets.md``: every departure of the MoMu-Diffusion ``cpu`` preset from the ``paper`` preset.

Generated from the resolved configs of Table 7 row #7 (the method every MoMu table trains) and
checked against the committed page by ``tests/unit/test_momu_presets.py``::

    python -m momu.methods.momu.presets_doc docs/presets.md
"""

from __future__ import annotations

import argparse
from pathlib import Path

from momu.engine.presets import departures, departures_table
from momu.engine.table import parse_table_args, resolve_row_configs
from momu.methods.momu.recipes import table7_spec

__all__ = ["presets_page"]

_INTRO = """# Presets: where the cpu preset departs from the paper

Every recipe has three presets. `paper` pins every value the paper gives (MoMu-Diffusion:
`recipes/configs/momu_paper.yaml`; Tables 8–9, §4–5, App. A–E) and marks where the paper is silent;
`cpu` (`recipes/configs/momu.yaml`) is what runs on a laptop CPU in well under an hour per seed
and keeps the paper's stages and losses at a small size, plus the devices the conditioning study
found necessary at that size (`benchmarks/momu_conditioning_study.py`); `smoke` shrinks `cpu`
further so every row runs in seconds (its numbers mean nothing).

The table below is generated from the resolved configs of Table 7 row #7 — the method every MoMu
table trains — by `python -m momu.methods.momu.presets_doc docs/presets.md`, and a test fails when
it no longer matches the configs. A key is listed when its resolved value differs; `—` means the
key does not exist on that side (the node is `null` or another part).

"""


def presets_page() -> str:
    """The page's Markdown (intro + the generated departures table of MoMu Table 7 row #7)."""
    spec = table7_spec()
    cfgs = {
        preset: resolve_row_configs(spec, parse_table_args(spec, ["--preset", preset, "--rows", "#7"]))["#7"]
        for preset in ("paper", "cpu")
    }
    rows = departures(cfgs["paper"], cfgs["cpu"])
    return _INTRO + "## MoMu-Diffusion (Table 7 row #7)\n\n" + departures_table(rows)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description="Write docs/presets.md from the preset configs.")
    parser.add_argument("out", type=Path)
    args = parser.parse_args(argv)
    args.out.write_text(presets_page())


if __name__ == "__main__":
    main()
