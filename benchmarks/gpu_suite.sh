#!/usr/bin/env bash
# The GPU check, in six stages, each meant as one command of at most 8 minutes on a fresh GPU
# machine:
#   peers   MuJoCo Warp and Myriad on the same models (gpu_peers.py; PEERS_ARGS: more of its
#           arguments), then the throughput table (throughput.py) in the time left
#   lanes   the cooperative kernels' lanes per world swept (lane_sweep.py; LANES_ARGS,
#           LANES_BUDGET_S 150)
#   tests   the test suite on CUDA, one pytest process per file
#   soak    every task under random actions for two episode lengths: nothing may go non-finite
#   loop    the PPO loop's rollout and update three ways each: rl_games', with nothing read
#           back, and captured as CUDA graphs (loop_steps.py; LOOP_RUNS, LOOP_BUDGET_S 240)
#   train   short training runs that time the paper's milestones
#   isaacgym  (not in the default list) the isaacgym layer's cost against Myriad's own API,
#           and AnymalTerrain on its height field against the original's triangle mesh
# Run from the repository root on a machine with an NVIDIA GPU (benchmarks/device_bundle.sh packs
# the packages it lacks and the kernel cache, and prints the calls), with the engine's CUDA kernels
# compiled beforehand on the CPU machine (a cold NVRTC build is minutes of idle device time;
# MuJoCo Warp's kernels are not in that cache and compile in the peers stage):
#   python benchmarks/precompile_cuda.py --arch 90 --cache .device/kcache     # here (no GPU)
#   WARP_CACHE_PATH=.device/kcache bash benchmarks/gpu_suite.sh peers         # there, one stage
#   bash benchmarks/gpu_suite.sh                  # all six: peers lanes tests soak loop train
# Each stage prints its budget first and, last, what it skipped to stay inside it. Budgets, in
# seconds: PEERS_S (the whole peers stage, 480) of which PEERS_BUDGET_S (240) for gpu_peers.py;
# TEST_TIMEOUT (420, per test file; the files run side by side); SOAK_BUDGET_S (420);
# LOOP_BUDGET_S (240); TRAIN_BUDGET_S (450). Logs go to $LOGS (default gpu_logs/); the tables are printed as Markdown
# for docs/.
set -uo pipefail
cd "$(dirname "$0")/.."
DEVICE=${DEVICE:-cuda:0}
LOGS=${LOGS:-gpu_logs}
mkdir -p "$LOGS"
stages=${*:-peers lanes tests soak loop train}
status=0
export PYTHONUNBUFFERED=1

for stage in $stages; do
  start=$SECONDS
  case $stage in
    peers)
      budget=${PEERS_S:-480} peers_budget=${PEERS_BUDGET_S:-240}
      echo "== peers on $DEVICE: budget $budget s (gpu_peers $peers_budget s, then throughput.py)"
      python3 benchmarks/gpu_peers.py --device "$DEVICE" --budget-s "$peers_budget" \
        --json "$LOGS/peers.json" ${PEERS_ARGS:-} 2>&1 | tee "$LOGS/peers.log"
      [ "${PIPESTATUS[0]}" -eq 0 ] || status=1
      skipped="gpu_peers.py: $(sed -n 's/^skipped: //p' "$LOGS/peers.log")"
      left=$((budget - (SECONDS - start)))
      if [ "$left" -lt 30 ]; then
        skipped+="; throughput.py (${left} s left)"
      else
        # throughput.py prints each row as it is measured: a cut leaves the rows before it
        timeout "$left" python3 benchmarks/throughput.py --device "$DEVICE" --seconds 2 2>&1 \
          | tee "$LOGS/throughput.log"
        rc=${PIPESTATUS[0]}
        [ "$rc" -eq 124 ] && skipped+="; throughput.py rows after the last printed (cut at $left s)"
        [ "$rc" -eq 0 ] || [ "$rc" -eq 124 ] || status=1
      fi ;;
    tests)
      # one pytest process per test file, all at once: most tests step 1-4 envs, which leave
      # the GPU idle, so files run side by side (the slowest, 10,000 steps of 4 models in
      # test_robustness, sets the wall time); tests that do not take the `device` fixture are
      # skipped (they run in the CPU suite). A file still running at TEST_TIMEOUT is stopped
      # and reported as skipped, not failed.
      timeout_s=${TEST_TIMEOUT:-420}
      echo "== tests on $DEVICE (one process per file): budget $timeout_s s per file, side by side"
      rm -rf "$LOGS/tests" && mkdir -p "$LOGS/tests"
      for f in tests/test_*.py; do
        name=$(basename "$f" .py)
        (timeout "$timeout_s" python3 -m pytest -q -rfEs --device "$DEVICE" -p no:cacheprovider \
           --durations=3 "$f" > "$LOGS/tests/$name.log" 2>&1
         echo "$name exit $?" >> "$LOGS/tests/exit_codes") &
      done
      wait
      for f in "$LOGS"/tests/test_*.log; do echo "#### $f"; cat "$f"; done > "$LOGS/tests.log"
      sort "$LOGS/tests/exit_codes"
      grep -hE "^(FAILED|ERROR)|[0-9]+ (passed|failed)" "$LOGS/tests.log"
      grep -v " exit 124$" "$LOGS/tests/exit_codes" | grep -q "exit [^0]" && status=1
      timed_out=$(awk '$3 == 124 {print $1}' "$LOGS/tests/exit_codes" | sort | paste -sd' ')
      skipped="${timed_out:+the rest of $timed_out (stopped at $timeout_s s)}"
      rm -rf "$LOGS/tests" ;;
    lanes)
      # lanes per world of the cooperative kernels: each count's stage times, the best per kind
      # of work, the default, and the same state from the same solve lane count
      lanes_budget=${LANES_BUDGET_S:-150}
      echo "== lanes on $DEVICE: budget $lanes_budget s"
      timeout "$lanes_budget" python3 benchmarks/lane_sweep.py --device "$DEVICE" \
        ${LANES_ARGS:-} 2>&1 | tee "$LOGS/lanes.log"
      rc=${PIPESTATUS[0]}
      [ "$rc" -eq 124 ] && skipped="lane_sweep.py after the last printed (cut at $lanes_budget s)"
      [ "$rc" -eq 0 ] || [ "$rc" -eq 124 ] || status=1 ;;
    soak)
      soak_budget=${SOAK_BUDGET_S:-420}
      echo "== soak on $DEVICE: budget $soak_budget s"
      python3 benchmarks/soak.py --device "$DEVICE" --budget-s "$soak_budget" 2>&1 \
        | tee "$LOGS/soak.log"
      [ "${PIPESTATUS[0]}" -eq 0 ] || status=1
      skipped=$(sed -n 's/^skipped: //p' "$LOGS/soak.log") ;;
    loop)
      # task:envs pairs; each builds its agent, runs two epochs, then times the rollout and the
      # update three ways, interleaved (a cut leaves the tasks before it)
      budget=${LOOP_BUDGET_S:-240} dropped=()
      echo "== loop on $DEVICE: budget $budget s"
      for spec in ${LOOP_RUNS:-Ant:4096 Humanoid:4096 ShadowHand:16384}; do
        left=$((budget - (SECONDS - start)))
        if [ "$left" -lt 40 ]; then dropped+=("$spec ($left s left)"); continue; fi
        timeout "$left" python3 benchmarks/loop_steps.py --device "$DEVICE" \
          --task "${spec%%:*}" --envs "${spec##*:}" --repeats 6 < /dev/null 2>&1 \
          | tee -a "$LOGS/loop_steps.log" | grep -E "^(\||[A-Za-z]+ on )"
        rc=${PIPESTATUS[0]}
        [ "$rc" -eq 124 ] && dropped+=("$spec (cut at $left s)")
        [ "$rc" -eq 0 ] || [ "$rc" -eq 124 ] || status=1
      done
      skipped=$(IFS=';'; echo "${dropped[*]}") ;;
    train)
      # task, seconds of training, milestones (the paper's: Ant 3000 in 20 s, Humanoid 5000 in
      # 4 min, Ingenuity 5000 in 30 s). A run is dropped when its seconds and the start-up of
      # the run before (building, kernel loads, the milestone check; 30 s before the first) do
      # not fit what is left of TRAIN_BUDGET_S. TRAIN_ARGS: more overrides for every run
      # (TRAIN_ARGS="capture_step=true capture_update=true": the env step and the PPO minibatch
      # step each as one CUDA graph).
      budget=${TRAIN_BUDGET_S:-450} overhead=30 dropped=()
      echo "== train on $DEVICE: budget $budget s"
      while read -r task seconds milestones; do
        left=$((budget - (SECONDS - start)))
        if [ $((seconds + overhead)) -gt "$left" ]; then
          dropped+=("$task (${seconds} s + ~${overhead} s, $left s left)")
          continue
        fi
        echo "== $task: 4096 envs, ${seconds} s"
        run_start=$SECONDS
        exp=gpu_${task}_$(date +%s)
        python3 -m myriad.cli train task="$task" device="$DEVICE" num_envs=4096 \
          max_time_s="$seconds" experiment="$exp" train_dir="$LOGS/runs" ${TRAIN_ARGS:-} \
          < /dev/null 2>&1 \
          | tee "$LOGS/train_$task.log" | grep -E "^(building|built|training|done)|epoch +[0-9]*0/"
        python3 benchmarks/milestones.py "$LOGS/runs/$exp" $milestones < /dev/null || status=1
        rm -rf "$LOGS/runs/$exp/nn" "$LOGS/runs/$exp/summaries"    # keep the curve and summary
        overhead=$((SECONDS - run_start - seconds))
      done <<< "${TRAIN_RUNS:-Ant 60 1000 3000 6000
Ingenuity 45 1000 5000
Humanoid 240 1000 3000 5000
Anymal 120 10 40}"
      skipped=$(IFS=';'; echo "${dropped[*]}") ;;
    isaacgym)
      # issue 41: what the isaacgym layer costs on the GPU pipeline (the Ant loop through
      # isaacgym and through Myriad's API, alternating rounds), at two env counts
      echo "== isaacgym layer on $DEVICE"
      for envs in ${ISAACGYM_ENVS:-4096 16384}; do
        timeout 200 python3 benchmarks/isaacgym_layer.py --device "$DEVICE" --envs "$envs" \
          --rounds 10 --steps 20 2>&1 | tee -a "$LOGS/isaacgym_layer.log" | grep -v "^Module"
      done
      # the original's terrain is a 4.8 M-triangle mesh (IsaacGymEnvs, legged_gym): its cost
      # against the height field it came from, in AnymalTerrain
      timeout 200 python3 benchmarks/terrain_mesh.py --device "$DEVICE" --envs 4096 \
        --rounds 6 --steps 20 2>&1 | tee -a "$LOGS/terrain_mesh.log" | grep -v "^Module" ;;
    *) echo "unknown stage $stage (peers, lanes, tests, soak, loop, train, isaacgym)"; exit 2 ;;
  esac
  echo "== $stage: $((SECONDS - start)) s; skipped to stay inside the budget: ${skipped:-nothing}"
done
exit $status
