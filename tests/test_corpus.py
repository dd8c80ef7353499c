"""Third-party robots under random actuation stay finite (a subset of `benchmarks/corpus.py`).

Models their users bring first: the MJCF assets gymnasium ships and URDFs of example-robot-data
(installed by the `anymal` extra, part of `all`), loaded as the benchmark loads them (mobile
robots on a floating base above a ground). Each runs 1 s of random actuation on 2 envs at the
default `SimParams`. The robots here all went non-finite before Myriad dropped collision pairs
that overlap at rest (Solo-12 at rest with no input, in its fourth step), or are the
well-behaved references beside them. The whole corpus, with MuJoCo's figures beside Myriad's, is
the benchmark.
"""

import os
import sys

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "benchmarks"))
corpus = pytest.importorskip("corpus")

# name: (largest joint speed allowed, largest limit excess allowed or None: not checked)
SUBSET = {
    "gymnasium/humanoid": (150.0, 0.05),
    "solo/solo12": (150.0, 0.05),
    "go2/go2": (150.0, None),
    "talos_data/talos_left_arm": (150.0, 0.05),
    "ur/ur10_robot": (150.0, 0.05),
}


@pytest.fixture(scope="module")
def loaders():
    if corpus.robots_folder() is None:
        pytest.skip("example-robot-data is not installed (pip install -e '.[all]')")
    return {name: loader for name, _, loader in corpus.corpus_models()}


@pytest.mark.parametrize("name", list(SUBSET))
def test_third_party_robot_stays_finite_under_random_actuation(name, loaders):
    fastest, limit_excess = SUBSET[name]
    result = corpus.run_model(name, loaders[name], seconds=1.0, envs=2)
    assert result["status"] == "ok", result
    assert result["finite"], result
    assert result["max_qd"] < fastest, result          # the joint speed cap is 100 rad/s
    if limit_excess is not None:
        assert result["limit_excess"] < limit_excess, result
