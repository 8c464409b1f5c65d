"""``results.json`` and ``results.md`` of the music-following benchmark.

The JSON keeps everything: per row and test the estimate, its interval, the raw and the gated verdict,
and every (song, seed) value. The Markdown prints, per direction, one table of the tests (mean [95 %
interval] and verdict), the BAS values, realism against the real data's 5th-95th percentile, the
controls, and which tests ground truth passes on this data.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from momu.following.checks import TESTS
from momu.following.realism import REALISM_KEYS
from momu.io import atomic_write_text, write_json

__all__ = ["write_results", "markdown", "format_cell", "TEST_TITLES", "DIRECTION_TITLES"]

TEST_TITLES = {
    "input_sensitivity": "input sensitivity (½ = as much as seeds)",
    "tempo_following": "tempo following: slope",
    "tempo_match": "tempo match: own − others",
    "beat_phase_bailando": "beat phase, BAS Bailando: own − half beat",
    "beat_phase_mint": "beat phase, BAS mint: own − half beat",
    "matched_bailando": "matched, BAS Bailando: own − partner",
    "matched_mint": "matched, BAS mint: own − partner",
}
DIRECTION_TITLES = {"dance": "music → dance", "music": "dance → music"}


def format_cell(d: Mapping[str, Any] | None, digits: int = 3, verdict: bool = True) -> str:
    """``estimate [low, high] **verdict**`` of a stored test or statistic (``—`` when absent)."""
    if not d:
        return "—"
    if "estimate" not in d:
        return str(d.get("verdict", "—"))
    est, low, high = d["estimate"], d["low"], d["high"]
    if est is None or est != est:
        text = "n/a"
    elif low != low:
        text = f"{est:.{digits}f}"
    else:
        text = f"{est:.{digits}f} [{low:.{digits}f}, {high:.{digits}f}]"
    if verdict and d.get("verdict"):
        text += f" **{d['verdict']}**" if d["verdict"] in ("passes", "fails") else f" *{d['verdict']}*"
    return text


def _direction_md(res: Mapping[str, Any]) -> list[str]:
    lines = [f"## {DIRECTION_TITLES[res['direction']]}", ""]
    gt = res["ground_truth_passes"]
    lines.append(
        f"Ground truth passes: {', '.join(gt) if gt else 'none of the tests'}. "
        "A test it does not pass gives no verdict on this data."
    )
    lines.append("")
    rows = res["rows"]
    lines.append("| row | " + " | ".join(TEST_TITLES[t] for t in TESTS) + " | within 5 % of the stretch |")
    lines.append("|---" * (len(TESTS) + 2) + "|")
    for r in rows:
        share = r["tests"]["tempo_following"].get("share_within_5pct")
        cells = [format_cell(r["tests"][t]) for t in TESTS]
        lines.append(f"| {r['id']} | " + " | ".join(cells) + f" | {format_cell(share, 2, False)} |")
    lines.append("")
    wrong = []
    for r in rows:
        for t, d in r["tests"].items():
            if (
                r["kind"] == "calibration"
                and d.get("expected")
                and d.get("raw_verdict")
                and d["raw_verdict"] != d["expected"]
            ):
                if d["expected"] == "fails" and d["raw_verdict"] != "passes":
                    continue  # built to fail: not passing is enough
                wrong.append(f"{r['id']} {d['raw_verdict']} {t} (expected: {d['expected']})")
    lines.append("Calibration: " + ("every row behaves as built." if not wrong else "; ".join(wrong) + "."))
    lines.append("")
    lines.append("| row | BAS Bailando (own beats) | BAS mint (own beats) |")
    lines.append("|---|---|---|")
    for r in rows:
        bas = r["bas"]
        cells = [format_cell(bas.get(v), 3, False) for v in ("bailando", "mint")]
        lines.append(f"| {r['id']} | " + " | ".join(cells) + " |")
    lines.append("")
    if res.get("reference_realism"):
        ref = res["reference_realism"]
        keys = [k for k in REALISM_KEYS if k in ref]
        lines.append(
            "Realism (mean over songs × seeds [95 % interval]; passes = inside the real data's 5th-95th "
            "percentile over every excerpt-long window of the real dances):"
        )
        lines.append("")
        lines.append("| row | " + " | ".join(keys) + " |")
        lines.append("|---" * (len(keys) + 1) + "|")
        lines.append(
            "| real 5th-95th pct | "
            + " | ".join(
                f"{ref[k]['p5']:.3f} – {ref[k]['p95']:.3f} ({ref[k]['windows']} windows)" for k in keys
            )
            + " |"
        )
        for r in rows:
            lines.append(
                f"| {r['id']} | " + " | ".join(format_cell(r.get("realism", {}).get(k)) for k in keys) + " |"
            )
        lines.append("")
    ctl = [r for r in rows if r.get("controls")]
    if ctl:
        lines.append(
            "Controls (descriptive; differs: ½ = the control changes the output as much as another seed, "
            "0 = the same output as for a song; energy: ratio of mean joint speed (dance) or difference "
            "of mean log-mel level in dB (music) to the song's output):"
        )
        lines.append("")
        lines.append("| row | control | differs | energy | tempo match |")
        lines.append("|---|---|---|---|---|")
        for r in ctl:
            for c, st in r["controls"].items():
                lines.append(
                    f"| {r['id']} | {c} | {format_cell(st.get('differs'), 3, False)} | "
                    f"{format_cell(st.get('energy'), 3, False)} | "
                    f"{format_cell(st.get('tempo_match'), 2, False)} |"
                )
        lines.append("")
    return lines


def markdown(results: Mapping[str, Any]) -> str:
    """The Markdown report of ``results`` (``{"directions": {...}, ...}``)."""
    lines = [f"# Music following: {results.get('data', '')}", ""]
    settings = results.get("settings", {})
    if settings:
        lines.append(", ".join(f"{k}: {v}" for k, v in settings.items()))
        lines.append("")
    for res in results["directions"].values():
        lines.append(
            f"Songs ({len(res['songs'])}): "
            + ", ".join(f"{s} ({t:.1f} BPM)" for s, t in zip(res["songs"], res["song_tempo_bpm"]))
        )
        lines.append("")
        lines += _direction_md(res)
    lines.append(
        "Cells: mean over songs × seeds [95 % two-level bootstrap interval: songs, then seeds within "
        "songs]. Verdict rules and test definitions: docs/following.md."
    )
    return "\n".join(lines) + "\n"


def write_results(results: Mapping[str, Any], out: str | Path) -> tuple[Path, Path]:
    """Write ``out/results.json`` and ``out/results.md``; a single direction's result is wrapped."""
    if "directions" not in results:
        results = {"directions": {results["direction"]: results}}
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    js = write_json(out / "results.json", results)
    md = atomic_write_text(out / "results.md", markdown(results))
    return js, md
