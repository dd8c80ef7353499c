"""Compile the engine's CUDA kernels ahead of time, on a machine with no GPU, into a kernel cache
that a GPU machine then loads instead of compiling.

    python benchmarks/precompile_cuda.py --arch 90 --cache .device/kcache     # here (no GPU)
    WARP_CACHE_PATH=.device/kcache python benchmarks/throughput.py             # there

A cold CUDA build of the engine runs NVRTC on one core for minutes (the narrowphase module alone
took 330 s on the 2-core CPU machine), which on a lent GPU machine is device time spent idle.
Warp's NVRTC is inside its own library and needs no driver, so the build can happen anywhere;
the cache key is the module's content hash, the same on both machines for the same source.

Warp loads these CUBINs when the GPU's driver is older than Warp's CUDA toolkit (Warp 1.19 with
CUDA 13.4 against the lent machines' 13.0 driver); with a newer driver it prefers PTX and
compiles (`warp.config.cuda_output = "cubin"` makes it take the cubins anyway).

Warp compiles a module once per block size it is launched with: every module for the default
(256 threads), and a module with cooperative kernels (`myriad.physics.lanes`: their last
argument is `lanes`) also for `runtime.BlockDim.threads`. A module whose source is already in the
cache (the same identifier, a cubin for each arch) is not compiled again: after a change, only
the changed modules take time; `--modules solver_tgs dynamics` compiles only those.
"""

from __future__ import annotations

import argparse
import importlib
import os
import time

import warp as wp


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--arch", type=int, nargs="+", default=[90],
                    help="compute capabilities: 90 = H100/H200, 89 = L4/RTX 4090, 80 = A100")
    ap.add_argument("--cache", required=True, help="kernel cache folder (WARP_CACHE_PATH there)")
    ap.add_argument("--modules", nargs="+", metavar="NAME",
                    help="only the engine modules whose name ends with one of these (e.g. "
                         "solver_tgs dynamics): a check that a change compiles for CUDA")
    args = ap.parse_args()
    wp.config.kernel_cache_dir = args.cache
    wp.init()
    from myriad.physics import runtime
    from myriad.physics.runtime.launch import BLOCK_DIM

    runtime.configure_modules()       # the build options the simulator uses: same hashes
    names = runtime.kernel_modules()
    if args.modules:
        unknown = [m for m in args.modules if not any(name.endswith(m) for name in names)]
        if unknown:
            ap.error(f"--modules {' '.join(unknown)}: no engine module ends with that name")
        names = [name for name in names if any(name.endswith(m) for m in args.modules)]
    for name in names:
        importlib.import_module(name)
        module = wp.get_module(name)
        if not module.kernels:
            continue
        default = module.options["block_dim"]
        cooperative = any(k.adj.args and k.adj.args[-1].label == "lanes"
                          for k in module.kernels.values())
        for block_dim in sorted({default, BLOCK_DIM.threads} if cooperative else {default}):
            start = time.perf_counter()
            ident = module.get_module_identifier(block_dim)
            cubins = [os.path.join(wp.config.kernel_cache_dir, ident, f"{ident}.sm{a}.cubin")
                      for a in args.arch]
            if all(os.path.isfile(c) for c in cubins):      # this source was compiled before
                print(f"{name}: {block_dim} threads per block, in the cache", flush=True)
                continue
            wp.set_module_options({"block_dim": block_dim}, name)
            wp.compile_aot_module(module, arch=args.arch, use_ptx=False)
            print(f"{name}: sm_{'/'.join(map(str, args.arch))}, {block_dim} threads per block, "
                  f"in {time.perf_counter() - start:.1f} s", flush=True)
        wp.set_module_options({"block_dim": default}, name)


if __name__ == "__main__":
    main()
