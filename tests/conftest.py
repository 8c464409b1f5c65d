"""Shared test set-up: hypothesis profiles, the `gpu` marker, offline tracking, real-data paths."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
import torch
from hypothesis import HealthCheck, settings

from tests.helpers.shared_data import shared_data_dir

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
