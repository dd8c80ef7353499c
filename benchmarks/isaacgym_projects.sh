#!/usr/bin/env bash
# Isaac Gym projects, unmodified, on Myriad's `isaacgym` package (docs/isaacgym.md):
# NVIDIA's IsaacGymEnvs through its own train.py (rl_games), ETH's legged_gym through its
# own scripts/train.py (rsl_rl 1.0.2, its PPO), and Unitree's unitree_rl_gym (its own copy of
# legged_gym with the G1, H1, H1-2 and Go2 tasks) the same way.
#
#   bash benchmarks/isaacgym_projects.sh setup isaacgymenvs [DIR]   # once: clone, environment
#   bash benchmarks/isaacgym_projects.sh setup legged_gym [DIR]
#   bash benchmarks/isaacgym_projects.sh setup unitree_rl_gym [DIR]
#   bash benchmarks/isaacgym_projects.sh train isaacgymenvs TASK [hydra overrides ...]
#   bash benchmarks/isaacgym_projects.sh train legged_gym TASK [its flags ...]
#   bash benchmarks/isaacgym_projects.sh train unitree_rl_gym TASK [its flags ...]   # g1 h1 h1_2 go2
#
# DIR (default ../<project> beside this repository, or $IGE_DIR / $LEGGED_GYM_DIR /
# $UNITREE_RL_GYM_DIR) is cloned at the commit below unless it exists. Its environment,
# DIR/.venv-myriad, sits on top of the Python environment Myriad is installed in (run setup
# with that environment active) and adds only what the project needs beside Myriad, its pins
# that Python 3.11 cannot install relaxed:
#   IsaacGymEnvs: gym 0.23.1 (its spaces), numpy < 2 (its np.Inf), scipy (its AMP motion
#     library); no warp-lang 0.10.1, pysdf, urdfpy (IndustReal and Factory only). Two edits,
#     outside its tasks and configs: tasks/__init__.py leaves the IndustReal imports out of its
#     task map (pysdf has no build for Python 3.11, and their SDF contacts are a PhysX feature
#     Myriad does not offer); learning/{amp_continuous,common_agent}.py read self.seq_length
#     (rl_games 1.6.5, the first on Python 3.11, renamed self.seq_len).
#   legged_gym: rsl_rl at its tag v1.0.2 (the API legged_gym is written for; cloned beside it),
#     matplotlib, scipy (its terrain), numpy < 2. No edit.
#   unitree_rl_gym: the same as legged_gym (its setup.py pins isaacgym, numpy 1.20 and MuJoCo
#     3.2.3, so it is installed without its dependencies; its sim-to-sim script runs on the
#     MuJoCo Myriad brings). No edit. benchmarks/unitree_pretrained.py runs Unitree's
#     pretrained policies in it.
# train runs on the CPU (sim and RL device cpu, headless) unless given other flags.
set -euo pipefail

IGE_COMMIT=aeed298638a1f7b5421b38f5f3cc2d1079b6d9c3          # IsaacGymEnvs 1.5.1
IGE_REPO=https://github.com/isaac-sim/IsaacGymEnvs.git
LG_COMMIT=8fa29acc6fd1910c3d9659eef6310bdd301cde0a           # legged_gym master, 2024
LG_REPO=https://github.com/leggedrobotics/legged_gym.git
UNITREE_COMMIT=276801e46c5d433564f24658bac64f254b7d2d4b     # unitree_rl_gym main, 2025
UNITREE_REPO=https://github.com/unitreerobotics/unitree_rl_gym.git
RSL_TAG=v1.0.2
RSL_REPO=https://github.com/leggedrobotics/rsl_rl.git
HERE=$(cd "$(dirname "$0")/../.." && pwd)

folder() {
    case "$1" in
        isaacgymenvs) echo "${IGE_DIR:-$HERE/IsaacGymEnvs}" ;;
        legged_gym) echo "${LEGGED_GYM_DIR:-$HERE/legged_gym}" ;;
        unitree_rl_gym) echo "${UNITREE_RL_GYM_DIR:-$HERE/unitree_rl_gym}" ;;
        *) echo "unknown project '$1': isaacgymenvs, legged_gym or unitree_rl_gym" >&2; exit 2 ;;
    esac
}

environment() {     # DIR: DIR/.venv-myriad reading the active environment's packages
    python - <<'EOF' || { echo "activate the environment Myriad is installed in first" >&2; exit 2; }
import myriad, isaacgym  # noqa: F401
EOF
    local base; base=$(python -c "import site; print(site.getsitepackages()[0])")
    python -m venv "$1/.venv-myriad"
    local own; own=$("$1/.venv-myriad/bin/python" -c "import site; print(site.getsitepackages()[0])")
    echo "import site; site.addsitedir('$base')" > "$own/myriad_base.pth"
}

setup() {
    local project=$1 dir; dir=${2:-$(folder "$1")}
    case "$project" in
        isaacgymenvs)
            [ -d "$dir" ] || { git clone "$IGE_REPO" "$dir"; git -C "$dir" checkout -q "$IGE_COMMIT"; }
            environment "$dir"
            "$dir/.venv-myriad/bin/pip" install -q "gym==0.23.1" "numpy<2" scipy
            "$dir/.venv-myriad/bin/pip" install -q --no-deps -e "$dir"
            sed -i -E 's/^from \.industreal/# (Myriad: pysdf, SDF contacts) from .industreal/; s/^(\s*"IndustReal)/# \1/' \
                "$dir/isaacgymenvs/tasks/__init__.py"
            sed -i 's/self\.seq_len\b/self.seq_length/g' \
                "$dir/isaacgymenvs/learning/amp_continuous.py" "$dir/isaacgymenvs/learning/common_agent.py" ;;
        legged_gym|unitree_rl_gym)
            if [ "$project" = legged_gym ]; then
                [ -d "$dir" ] || { git clone "$LG_REPO" "$dir"; git -C "$dir" checkout -q "$LG_COMMIT"; }
            else
                [ -d "$dir" ] || { git clone "$UNITREE_REPO" "$dir"; git -C "$dir" checkout -q "$UNITREE_COMMIT"; }
            fi
            [ -d "$dir/rsl_rl" ] || git clone -q --branch "$RSL_TAG" "$RSL_REPO" "$dir/rsl_rl"
            environment "$dir"
            "$dir/.venv-myriad/bin/pip" install -q matplotlib scipy "numpy<2"
            # a copy, not editable: it must come before Myriad's own rsl_rl (5.x) on the path
            "$dir/.venv-myriad/bin/pip" install -q --no-deps "$dir/rsl_rl"
            "$dir/.venv-myriad/bin/pip" install -q --no-deps -e "$dir" ;;
        *) folder "$project" >/dev/null ;;
    esac
    echo "$project ready in $dir; train with: bash $0 train $project <task>"
}

train() {
    local project=$1 task=$2; shift 2
    local dir; dir=$(folder "$project")
    [ -x "$dir/.venv-myriad/bin/python" ] || { echo "run: $0 setup $project first" >&2; exit 2; }
    case "$project" in
        isaacgymenvs)
            local extra=()
            # rl_games 1.6.5 compiles the model; AMP's gradient penalty needs a double backward,
            # which torch.compile does not support
            [ "$task" = HumanoidAMP ] && extra+=("+train.params.config.torch_compile=False")
            cd "$dir/isaacgymenvs"
            exec "$dir/.venv-myriad/bin/python" train.py "task=$task" sim_device=cpu \
                rl_device=cpu pipeline=cpu headless=True "${extra[@]}" "$@" ;;
        legged_gym|unitree_rl_gym)
            cd "$dir"
            exec "$dir/.venv-myriad/bin/python" legged_gym/scripts/train.py "--task=$task" \
                --sim_device=cpu --rl_device=cpu --headless "$@" ;;
    esac
}

case "${1:-}" in
    setup) [ $# -ge 2 ] || { echo "usage: $0 setup isaacgymenvs|legged_gym|unitree_rl_gym [DIR]" >&2; exit 2; }
           shift; setup "$@" ;;
    train) [ $# -ge 3 ] || { echo "usage: $0 train isaacgymenvs|legged_gym|unitree_rl_gym TASK [...]" >&2; exit 2; }
           shift; train "$@" ;;
    *) echo "usage: $0 setup isaacgymenvs|legged_gym|unitree_rl_gym [DIR] | train isaacgymenvs|legged_gym|unitree_rl_gym TASK [...]" >&2
       exit 2 ;;
esac
