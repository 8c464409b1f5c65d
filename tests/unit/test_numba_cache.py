"""Launched ranks get numba kernel caches of their own (numba/numba#10128 crashes otherwise)."""

from __future__ import annotations

from pathlib import Path

from momu._numba_cache import isolate_rank_cache


def test_each_launched_rank_gets_its_own_cache_folder(tmp_path: Path) -> None:
    folders = []
    for rank in ("0", "1"):
        env = {"LOCAL_RANK": rank, "XDG_CACHE_HOME": str(tmp_path)}
        folders.append(isolate_rank_cache(env))
        assert env["NUMBA_CACHE_DIR"] == folders[-1]
    assert folders == [str(tmp_path / "momu" / "numba" / f"rank-{r}") for r in (0, 1)]


def test_single_process_runs_and_a_users_setting_are_left_alone() -> None:
    env: dict[str, str] = {}
    assert isolate_rank_cache(env) is None and env == {}
    env = {"LOCAL_RANK": "1", "NUMBA_CACHE_DIR": "/mine"}
    assert isolate_rank_cache(env) is None and env["NUMBA_CACHE_DIR"] == "/mine"
