#!/usr/bin/env bash
# Everything a lent GPU machine needs from here, packed to travel in two calls (each call carries
# at most 64 MiB with the working tree): the Python packages its image lacks (Warp, MuJoCo,
# MuJoCo Warp, rl_games, Hydra, ...), unpacked and compressed as one xz stream, and the engine's
# CUDA kernels compiled here (precompile_cuda.py; NVRTC took 20 minutes on the 2-core machine on
# 2026-11-27, so start this first; modules already in .kc are skipped). Run from the repository
# root, with the project's environment active (Warp, MuJoCo and torch importable):
#
#   bash benchmarks/device_bundle.sh            # -> .device/w1/, .device/w2/, .device/kc/
#
# then, on the GPU machine (the commands are printed at the end):
#   call 1, carry .device/w1:  mkdir -p /root/dw && cp .device/w1/* /root/dw/
#   call 2, carry .device/w2:  unpack both, then the work (gpu_suite.sh stages, gpu_chunk.sh)
#   later calls, carry .device/kc: unpack the kernel cache again (a folder a call does not carry
#   is removed there), /tmp/site is still there on the same machine
set -euo pipefail
cd "$(git rev-parse --show-toplevel)"
grep -qxF '/.device/' .git/info/exclude 2>/dev/null || echo '/.device/' >> .git/info/exclude
grep -qxF '/.kc/' .git/info/exclude || echo '/.kc/' >> .git/info/exclude

python3 benchmarks/precompile_cuda.py --arch 90 --cache .kc > .device-precompile.log 2>&1 &
precompile=$!

../shared/tools/device-wheels.sh > /dev/null        # the wheels, as .device/part-*
site=$(mktemp -d) stage=$(mktemp -d)
cat .device/part-*/chunk.* | tar -x -C "$stage"
for w in "$stage"/wheels/*.whl; do python3 -m zipfile -e "$w" "$site"; done
rm -rf "$site"/warp/examples "$site"/warp/tests "$stage"
find "$site" -name __pycache__ -prune -exec rm -rf {} +
rm -rf .device && mkdir -p .device/w1 .device/w2 .device/kc
tar -C "$site" -cf - . | xz -7 -T2 > .device/site.tar.xz
rm -rf "$site"
size=$(stat -c %s .device/site.tar.xz)
split -b $(( (size + 1) / 2 )) -d -a 1 .device/site.tar.xz .device/site.tar.xz.
mv .device/site.tar.xz.0 .device/w1/ && mv .device/site.tar.xz.1 .device/w2/
rm .device/site.tar.xz

wait "$precompile" || { echo "precompile failed: .device-precompile.log"; exit 1; }
mv .device-precompile.log .device/
tar -C .kc -cf - . | xz -6 -T2 > .device/kc/kc.tar.xz
cp .device/kc/kc.tar.xz .device/w2/
du -sh .device/w1 .device/w2 .device/kc

cat <<'EOF'

On the GPU machine (device tool), one call right after the other (it goes back after 30 s idle):
  1. carry [".device/w1"]:
     mkdir -p /root/dw && cp .device/w1/* /root/dw/ && nvidia-smi -L
  2. carry [".device/w2"]:
     cat /root/dw/site.tar.xz.0 .device/w2/site.tar.xz.1 > /tmp/w.tar.xz && mkdir -p /tmp/site .kc && python3 -c "import tarfile; tarfile.open('/tmp/w.tar.xz').extractall('/tmp/site', filter='fully_trusted'); tarfile.open('.device/w2/kc.tar.xz').extractall('.kc', filter='fully_trusted')" && export PYTHONPATH=$PWD/src:/tmp/site WARP_CACHE_PATH=$PWD/.kc PYTHONUNBUFFERED=1 && LOGS=/tmp/gl bash benchmarks/gpu_suite.sh peers lanes tests; cp /tmp/gl/*.log $OUT/
  later calls, carry [".device/kc"]:
     mkdir -p .kc && python3 -c "import tarfile; tarfile.open('.device/kc/kc.tar.xz').extractall('.kc', filter='fully_trusted')" && export PYTHONPATH=$PWD/src:/tmp/site WARP_CACHE_PATH=$PWD/.kc PYTHONUNBUFFERED=1 && ...
EOF
