"""The second half of the CI chaos batch (test_chaos.py), in a file of its own so that it runs on a second
xdist worker beside the first half (``--dist loadfile`` keeps a file on one worker). Empty with
G1_CHAOS_PARTS=1 (``make chaos``: one batch)."""

from __future__ import annotations

from pathlib import Path

import pytest

from chaos.test_chaos import parts
from chaos.test_chaos import test_chaos_batch as run_batch

pytestmark = [pytest.mark.e2e, pytest.mark.sim]


@pytest.mark.parametrize(("first_seed", "count"), parts(1))
def test_chaos_batch_second_half(sdk_channels: int, tmp_path: Path, first_seed: int, count: int) -> None:
    run_batch(sdk_channels, tmp_path, first_seed, count)
