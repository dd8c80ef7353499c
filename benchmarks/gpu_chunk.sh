#!/usr/bin/env bash
# One chunk of a training run too long for one lent GPU machine (issue 42 item 4): resume the
# task's unfinished run from the repository, train for CHUNK_S seconds more, and put what the next chunk
# needs under $OUT, to be committed back. CHUNK_S: seconds of training (default 420).
#
#   on the GPU machine (repository root; wheels and kernel cache as in gpu_suite.sh):
#     TASK=ShadowHand CHUNK_S=420 bash benchmarks/gpu_chunk.sh
#   back here, with the files the call returned in DIR:
#     bash benchmarks/gpu_chunk.sh keep ShadowHand DIR && git add chunks/ShadowHand
#
# The unfinished run lives in chunks/<Task>/ (nn/last.pth, progress.csv, summary.json: what an
# exact resume reads; no TensorBoard files, no best-policy file), one per task, replaced at each
# chunk and removed when the task's policy ships (`python -m myriad.rl.shipped
# chunks/<Task>/nn/last.pth`). The chunk trains with `resume=auto`: the same run folder, its
# epoch count, optimizer, random generators and task state (terrain levels, schedules) go on
# where the last chunk stopped, and progress.csv's wall time goes on summing. A stop by the time
# limit saves at the end of the epoch, so CHUNK_S plus one epoch and the start-up (~30 s) must fit
# the call. More overrides: TRAIN_ARGS (e.g. num_envs=16384; keep them the same in every chunk).
set -uo pipefail
cd "$(dirname "$0")/.."
if [ "${1:-}" = keep ]; then                 # here: copy a returned chunk into the repository
  task=${2:?task} from=${3:?folder with last.pth, progress.csv, summary.json}
  mkdir -p "chunks/$task/nn"
  cp "$from/last.pth" "chunks/$task/nn/last.pth"
  cp "$from/progress.csv" "$from/summary.json" "chunks/$task/"
  python3 - "$task" <<'EOF'
import json, sys
s = json.load(open(f"chunks/{sys.argv[1]}/summary.json"))
print(f"chunks/{sys.argv[1]}: epoch {s['checkpoint_epoch']}, {s['env_steps']:,} env-steps, "
      f"{s['wall_s'] / 60:.1f} min of training, mean reward {s['mean_reward']:.1f}")
EOF
  exit
fi
TASK=${TASK:?set TASK} CHUNK_S=${CHUNK_S:-420}
DEVICE=${DEVICE:-cuda:0} OUT=${OUT:-gpu_logs/chunk_$TASK}
mkdir -p "$OUT"
export PYTHONUNBUFFERED=1
# max_time_s counts the run's whole training time, earlier chunks included
max_time=$(python3 -c "import json, sys
try: print(json.load(open(sys.argv[1]))['wall_s'] + float(sys.argv[2]))
except OSError: print(sys.argv[2])" "chunks/$TASK/summary.json" "$CHUNK_S")
python3 -m myriad.cli train task="$TASK" device="$DEVICE" train_dir=chunks experiment="$TASK" \
  resume=auto max_time_s="$max_time" ${TRAIN_ARGS:-} < /dev/null 2>&1 | tee "$OUT/train.log" \
  | grep -E "^(resuming|training|done|SIG)|epoch +[0-9]*0/"
rc=${PIPESTATUS[0]}
cp "chunks/$TASK/nn/last.pth" "chunks/$TASK/progress.csv" "chunks/$TASK/summary.json" "$OUT/" \
  || rc=1
ls -la "$OUT"
exit $rc
