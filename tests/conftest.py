import os
import random
import sys

import numpy as np
import pytest
import torch
import warp as wp

import myriad  # noqa: F401  (before any test imports MuJoCo: picks its headless GL backend)

sys.path.insert(0, os.path.dirname(__file__))  # tests/models.py
# benchmarks/: scenes and the robot corpus that tests share with the benchmarks
sys.path.insert(1, os.path.join(os.path.dirname(__file__), "..", "benchmarks"))
wp.config.log_level = wp.LOG_WARNING


def pytest_addoption(parser):
    parser.addoption("--device", default="cpu", help="Warp device to test on, e.g. cuda:0")


@pytest.fixture(scope="session")
def device(request):
    return request.config.getoption("--device")


@pytest.fixture(autouse=True)
def same_random_state():
    """Every test starts from the same random numbers, whatever ran before it in the process:
    torch seeds its default generator from the clock, and a task's randomization (ANYmal's
    friction buckets) drew different values in each run."""
    torch.manual_seed(0)
    np.random.seed(0)
    random.seed(0)


@pytest.fixture(scope="session")
def unshipped_task():
    """A task that ships no policy: play, eval and export of it with no run must fail (for a
    task that ships one they fall back to it, `myriad.rl.shipped`)."""
    from myriad.rl import shipped
    from myriad.tasks import TASKS
    return next(t for t in TASKS if t not in shipped.manifest())


def pytest_collection_modifyitems(config, items):
    """On a GPU (--device cuda:0) run only the tests that take the `device` fixture: the others
    do not depend on the device and run in the CPU suite."""
    if config.getoption("--device") == "cpu":
        return
    skip = pytest.mark.skip(reason="device-independent: covered by the CPU run")
    for item in items:
        if "device" not in getattr(item, "fixturenames", ()):
            item.add_marker(skip)
