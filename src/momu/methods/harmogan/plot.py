"""Bar plots of HarmoGAN's figures (Figs. 9, 11, 12) from a table's ``results.json``."""

from __future__ import annotations

import logging
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from momu.io import atomic_path

__all__ = ["bar_plot"]

log = logging.getLogger(__name__)


def bar_plot(result: Mapping[str, Any], path: Path) -> Path | None:
    """One panel per column: a bar per row and calibration row (mean over seeds ± the 95 % half-width).

    Returns the written path, or ``None`` when matplotlib is not installed (a plot never fails a table).
    """
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:  # pragma: no cover - the render extra is missing
        log.warning("bar plot skipped: matplotlib is not installed")
        return None
    rows = [*result["rows"], *({**c, "name": f"{c['name']} (calibration)"} for c in result["calibration"])]
    columns = [c for c in result["columns"] if any(c["key"] in r["metrics"] for r in rows)]
    if not columns:
        return None
    fig, axes = plt.subplots(
        1, len(columns), figsize=(3.2 * len(columns) + 2, 0.35 * len(rows) + 1.5), squeeze=False
    )
    for ax, col in zip(axes[0], columns):
        names = [r["name"] for r in rows if col["key"] in r["metrics"]]
        values = [r["metrics"][col["key"]] for r in rows if col["key"] in r["metrics"]]
        errors = [
            (r.get("interval") or {}).get(col["key"]) or 0.0 for r in rows if col["key"] in r["metrics"]
        ]
        y = np.arange(len(names))
        ax.barh(
            y, values, xerr=errors, color=["C0" if "calibration" not in n else "C7" for n in names], capsize=3
        )
        ax.set_yticks(y, names if ax is axes[0][0] else [""] * len(names), fontsize=7)
        ax.invert_yaxis()
        ax.set_title(col["label"], fontsize=8)
        ax.tick_params(axis="x", labelsize=7)
    fig.suptitle(result["title"], fontsize=9)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=110)
    plt.close(fig)
    return path
