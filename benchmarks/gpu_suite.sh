#!/usr/bin/env bash
# The GPU check: the test suite on CUDA, then the throughput table, then short training runs
# that time the paper's milestones. Run from the repository root on a machine with an NVIDIA GPU:
#   bash benchmarks/gpu_suite.sh                 # all three
#   bash benchmarks/gpu_suite.sh tests           # or any of: tests throughput train
# Logs go to $LOGS (default gpu_logs/); the tables are printed as Markdown for docs/.
set -uo pipefail
cd "$(dirname "$0")/.."
DEVICE=${DEVICE:-cuda:0}
LOGS=${LOGS:-gpu_logs}
mkdir -p "$LOGS"
stages=${*:-tests throughput train}
status=0
export PYTHONUNBUFFERED=1

for stage in $stages; do
  case $stage in
    tests)
      # one pytest process per test file, all at once: most tests step 1-4 envs, which leave
      # the GPU idle, so files run side by side (the slowest, 10,000 steps of 4 models in
      # test_robustness, sets the wall time); tests that do not take the `device` fixture are
      # skipped (they run in the CPU suite)
      echo "== test suite on $DEVICE (one process per file)"
      rm -rf "$LOGS/tests" && mkdir -p "$LOGS/tests"
      for f in tests/test_*.py; do
        name=$(basename "$f" .py)
        (timeout "${TEST_TIMEOUT:-900}" python3 -m pytest -q -rfEs --device "$DEVICE" -p no:cacheprovider \
           --durations=3 "$f" > "$LOGS/tests/$name.log" 2>&1
         echo "$name exit $?" >> "$LOGS/tests/exit_codes") &
      done
      wait
      for f in "$LOGS"/tests/test_*.log; do echo "#### $f"; cat "$f"; done > "$LOGS/tests.log"
      sort "$LOGS/tests/exit_codes"
      grep -hE "^(FAILED|ERROR)|[0-9]+ (passed|failed)" "$LOGS/tests.log"
      grep -q "exit [^0]" "$LOGS/tests/exit_codes" && status=1
      rm -rf "$LOGS/tests" ;;
    throughput)
      echo "== throughput on $DEVICE"
      python3 benchmarks/throughput.py --device "$DEVICE" 2>&1 | tee "$LOGS/throughput.log"
      [ "${PIPESTATUS[0]}" -eq 0 ] || status=1 ;;
    train)
      # task, seconds of training, milestones (the paper's: Ant 3000 in 20 s, Humanoid 5000 in
      # 4 min, Ingenuity 5000 in 30 s)
      while read -r task seconds milestones; do
        echo "== $task: 4096 envs, ${seconds} s"
        exp=gpu_${task}_$(date +%s)
        python3 -m myriad.cli train task="$task" device="$DEVICE" num_envs=4096 \
          max_time_s="$seconds" experiment="$exp" train_dir="$LOGS/runs" 2>&1 \
          | tee "$LOGS/train_$task.log" | grep -E "^(building|built|training|done)|epoch +[0-9]*0/"
        python3 benchmarks/milestones.py "$LOGS/runs/$exp" $milestones || status=1
        rm -rf "$LOGS/runs/$exp/nn" "$LOGS/runs/$exp/summaries"    # keep the curve and summary
      done <<< "${TRAIN_RUNS:-Ant 60 1000 3000 6000
Ingenuity 45 1000 5000
Humanoid 240 1000 3000 5000
Anymal 120 10 40}"
      ;;
    *) echo "unknown stage $stage (tests, throughput, train)"; exit 2 ;;
  esac
done
exit $status
