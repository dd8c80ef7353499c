#!/usr/bin/env bash
# Renamed: benchmarks/isaacgym_projects.sh (IsaacGymEnvs and legged_gym). This forwards.
set -euo pipefail
cmd=${1:?usage: $0 setup [DIR] | train TASK [...]}; shift
exec bash "$(dirname "$0")/isaacgym_projects.sh" "$cmd" isaacgymenvs "$@"
