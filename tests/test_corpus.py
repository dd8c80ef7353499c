"""Third-party robots under random actuation stay finite (a subset of `benchmarks/corpus.py`).

Models their users bring first: the MJCF assets gymnasium ships and URDFs of example-robot-data
(installed by the `anymal` extra, part of `all`), loaded as the benchmark loads them (mobile
robots on a floating base above a ground). Each runs 1 or 2 s of random actuation on 2 or 4
envs at the default `SimParams`. The robots here all went non-finite before Myriad dropped
collision pairs that overlap at rest (Solo-12 at rest with no input, in its fourth step) and
contacts its joints cannot move along their normal (UR5), or are the well-behaved references
beside them. The whole corpus, with MuJoCo's figures beside Myriad's, is
the benchmark.
"""

import pytest

corpus = pytest.importorskip("corpus")      # benchmarks/corpus.py (conftest puts it on the path)

# name: (seconds, envs, largest joint speed allowed, largest limit excess allowed or None)
SUBSET = {
    "gymnasium/humanoid": (1.0, 2, 150.0, 0.05),
    "solo/solo12": (1.0, 2, 150.0, 0.05),
    "go2/go2": (1.0, 2, 150.0, 0.05),
    # a URDF MuJoCo rejects (inertias not positive definite), loaded by myriad.load_asset's
    # repairs as Isaac Gym would load it
    "go1/go1": (1.0, 2, 150.0, 0.05),
    "talos_data/talos_left_arm": (1.0, 2, 150.0, 0.05),
    "ur/ur10_robot": (1.0, 2, 150.0, 0.05),
    # a contact between two links along a normal its joints can barely move (J M⁻¹ Jᵀ tiny):
    # non-finite at 1.17 s in one of four envs before such contacts were dropped
    "ur/ur5_robot": (2.0, 4, 150.0, 0.05),
}


@pytest.fixture(scope="module")
def loaders():
    if corpus.robots_folder() is None:
        pytest.skip("example-robot-data is not installed (pip install -e '.[all]')")
    return {name: loader for name, _, loader in corpus.corpus_models()}


@pytest.mark.parametrize("name", list(SUBSET))
def test_third_party_robot_stays_finite_under_random_actuation(name, loaders):
    seconds, envs, fastest, limit_excess = SUBSET[name]
    result = corpus.run_model(name, loaders[name], seconds=seconds, envs=envs)
    assert result["status"] == "ok", result
    assert result["finite"], result
    assert result["max_qd"] < fastest, result          # the joint speed cap is 100 rad/s
    if limit_excess is not None:
        assert result["limit_excess"] < limit_excess, result
