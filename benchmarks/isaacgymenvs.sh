#!/usr/bin/env bash
# IsaacGymEnvs, unmodified task files and configs, trained through its own train.py on Myriad's
# `isaacgym` package (docs/isaacgym.md, "IsaacGymEnvs").
#
#   bash benchmarks/isaacgymenvs.sh setup [DIR]          # once: clone, make its environment
#   bash benchmarks/isaacgymenvs.sh train TASK [hydra overrides ...]
#
# DIR (default ../IsaacGymEnvs, or $IGE_DIR) is cloned at the commit below unless it exists.
# Its environment, DIR/.venv-myriad, sits on top of the Python environment Myriad is installed
# in (run setup with that environment active): it adds only what IsaacGymEnvs needs beside
# Myriad, with the pins Python 3.11 cannot install relaxed:
#   gym 0.23.1 (its spaces), numpy < 2 (its np.Inf), scipy (its AMP motion library);
#   no warp-lang 0.10.1, pysdf, urdfpy (IndustReal and Factory only).
# Two edits to IsaacGymEnvs, both outside its tasks and configs:
#   - tasks/__init__.py: the IndustReal imports left out of the task map (pysdf has no build
#     for Python 3.11, and their SDF contacts are a PhysX feature Myriad does not offer);
#   - learning/{amp_continuous,common_agent}.py: self.seq_len -> self.seq_length (rl_games
#     1.6.5, the first on Python 3.11, renamed it; HumanoidAMP's learner reads it).
# train runs on the CPU unless given sim_device=cuda:0 rl_device=cuda:0 pipeline=gpu.
set -euo pipefail

COMMIT=aeed298638a1f7b5421b38f5f3cc2d1079b6d9c3     # IsaacGymEnvs 1.5.1
REPO=https://github.com/isaac-sim/IsaacGymEnvs.git
DIR=${IGE_DIR:-$(cd "$(dirname "$0")/../.." && pwd)/IsaacGymEnvs}

setup() {
    [ $# -ge 1 ] && DIR=$1
    python - <<'EOF' || { echo "activate the environment Myriad is installed in first" >&2; exit 2; }
import myriad, isaacgym  # noqa: F401
EOF
    if [ ! -d "$DIR" ]; then
        git clone "$REPO" "$DIR"
        git -C "$DIR" checkout -q "$COMMIT"
    fi
    local base; base=$(python -c "import site; print(site.getsitepackages()[0])")
    python -m venv "$DIR/.venv-myriad"
    local own; own=$("$DIR/.venv-myriad/bin/python" -c "import site; print(site.getsitepackages()[0])")
    echo "import site; site.addsitedir('$base')" > "$own/myriad_base.pth"
    "$DIR/.venv-myriad/bin/pip" install -q "gym==0.23.1" "numpy<2" scipy
    "$DIR/.venv-myriad/bin/pip" install -q --no-deps -e "$DIR"
    sed -i -E 's/^from \.industreal/# (Myriad: pysdf, SDF contacts) from .industreal/; s/^(\s*"IndustReal)/# \1/' \
        "$DIR/isaacgymenvs/tasks/__init__.py"
    sed -i 's/self\.seq_len\b/self.seq_length/g' \
        "$DIR/isaacgymenvs/learning/amp_continuous.py" "$DIR/isaacgymenvs/learning/common_agent.py"
    echo "IsaacGymEnvs ready in $DIR; train with: bash $0 train Cartpole"
}

train() {
    [ $# -ge 1 ] || { echo "usage: $0 train TASK [hydra overrides ...]" >&2; exit 2; }
    local task=$1; shift
    [ -x "$DIR/.venv-myriad/bin/python" ] || { echo "run: $0 setup first" >&2; exit 2; }
    local extra=()
    # rl_games 1.6.5 compiles the model; AMP's gradient penalty needs a double backward, which
    # torch.compile does not support
    [ "$task" = HumanoidAMP ] && extra+=("+train.params.config.torch_compile=False")
    cd "$DIR/isaacgymenvs"
    exec "$DIR/.venv-myriad/bin/python" train.py "task=$task" sim_device=cpu rl_device=cpu \
        pipeline=cpu headless=True "${extra[@]}" "$@"
}

case "${1:-}" in
    setup) shift; setup "$@" ;;
    train) shift; train "$@" ;;
    *) echo "usage: $0 setup [DIR] | train TASK [hydra overrides ...]" >&2; exit 2 ;;
esac
