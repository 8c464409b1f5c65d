"""Shared test set-up: hypothesis profiles, the `gpu` marker, offline tracking, real-data paths."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import pytest
import torch
from hypothesis import HealthCheck, settings

from tests.helpers.shared_data import shared_data_dir


# One numba cache per pytest worker, set before anything imports numba and filled here, before any
# test starts a run in other processes (which inherit the folder and only read it): librosa caches
# its kernels on disk, and processes that fill one cold cache together can load a mismatched kernel
# pair and crash (numba/numba#10128: on a fresh install the recipe runs of the integration tests
# died with SIGSEGV, and a CI run lost a worker in tests/unit/test_eval_cli.py).
def _fill_own_numba_cache() -> None:
    worker = os.environ.get("PYTEST_XDIST_WORKER", "main")
    os.environ.setdefault("NUMBA_CACHE_DIR", str(Path(tempfile.gettempdir()) / "momu-test-numba" / worker))
    from momu.metrics._audio import warm_librosa_kernels  # imports numba: after the variable is set

    warm_librosa_kernels()


_fill_own_numba_cache()

os.environ.setdefault("WANDB_MODE", "disabled")
os.environ.setdefault("HF_HUB_OFFLINE", "1")

# `ci`: bounded examples and no deadline (shared 2-core machines make timings noisy).
settings.register_profile(
    "ci", max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow], print_blob=True
)
settings.register_profile("dev", max_examples=100, deadline=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))

# One intra-op thread per test process: on small shared machines torch's default thread pool makes
# small-tensor tests many times slower (nox runs two pytest workers on two cores).
torch.set_num_threads(int(os.environ.get("MOMU_TEST_THREADS", "1")))
# ... and the runs the tests start (make_accelerator sets the count from MOMU_NUM_THREADS)
os.environ.setdefault("MOMU_NUM_THREADS", os.environ.get("MOMU_TEST_THREADS", "1"))

SHARED_DATA = shared_data_dir()  # ../shared/data beside the checkout (or the main checkout of a worktree)


def _cuda_available() -> bool:
    return torch.cuda.is_available()


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if _cuda_available():
        return
    skip_gpu = pytest.mark.skip(reason="needs CUDA")
    for item in items:
        if item.get_closest_marker("gpu") is not None:  # not `in keywords`: folder names count there
            item.add_marker(skip_gpu)


@pytest.fixture
def shared_data() -> Path:
    """The real-data folder shipped beside the project (skips the test where absent)."""
    if not SHARED_DATA.is_dir():
        pytest.skip(f"real data not found at {SHARED_DATA}")
    return SHARED_DATA
