"""Cooperative kernels: the threads of one world ("lanes") share its work.

A cooperative kernel is launched over blocks (`runtime.Runtime.launch_lanes`); a block of
`wp.block_dim()` threads holds block_dim / lanes worlds, each world's `lanes` consecutive
threads. The lanes of a world take its bodies of one tree level (`level_range`, `level_body`),
its dofs or its joints in turn (`for i in range(lo + lane, hi, lanes)`), and when lanes > 1 the
block waits at `sync()` wherever the next loop reads what another lane wrote (one lane needs no
wait, and a kernel launched one thread per world must never reach one). Every world of a model
runs the same loops (the same tree, the same counts), so all threads of a block reach the same
`sync()` calls; a thread past the last world (`active` false) runs them with no items.

The same source runs with one lane per world (the CPU's path: one thread walks its world's
items in index order, as a serial loop does) and with many (CUDA; the CPU too with
`MYRIAD_CPU_BLOCK_DIM`, through Warp's cooperative CPU fibers). Each item is computed by one
lane in the same arithmetic either way, and sums keep a fixed order (a parent gathers its
children, highest index first), so the results do not depend on the lane count or on timing:
bit for bit, not only up to rounding. One exception: the solve's J·v sums (`solver_tgs._dot`)
add each lane's part in lane order, so they depend on the solve's lane count (never on timing:
the same count gives the same bits on every run).

The loops over a world's items are written inline or in functions marked `inline=True`: a CPU
build passes structs to a function by value, so a call per body would copy the model's arrays
(4 KB) each time. (A CPU kernel also copies its struct arguments once per thread, that is, per
world: keep what kernels take small.)
"""

import warp as wp

from .structs import ModelArrays


@wp.func_native("WP_TILE_SYNC();")
def sync():
    """Wait until every thread of the block got here; the writes before it are visible after."""
    ...


@wp.func_native("""
#if defined(__CUDA_ARCH__)
    return lanes == 32;
#else
    return false;
#endif
""")
def warp_lanes(lanes: int) -> bool:
    """Whether a world's `lanes` are one whole warp (CUDA, 32 lanes; a world's lanes start at a
    multiple of `lanes` in a block of a multiple of 32 threads): its sums can then pass through
    the warp's registers (`warp_sum`) instead of device memory and a wait of the block."""
    ...


@wp.func_native("""
#if defined(__CUDA_ARCH__)
    float s = x;
    for (int k = 16; k > 0; k >>= 1) s += __shfl_xor_sync(0xffffffffu, s, k);
    __syncwarp();
    return s;
#else
    return x;
#endif
""")
def warp_sum(x: float) -> float:
    """x summed over the 32 lanes of the calling warp, the same bits on every lane (a butterfly:
    at each step two lanes add the same two values, in either order); every lane's writes before
    it are seen by all after it (`__syncwarp`). Only where `warp_lanes` holds; every lane of the
    warp must call it."""
    ...


@wp.func(inline=True)
def world_lane(block: int, thread: int, lanes: int, nworld: int):
    """(world, lane, active) of thread `thread` of block `block`: `active` is false for the
    threads of a last, partly filled block that hold no world."""
    e = block * (wp.block_dim() // lanes) + thread // lanes
    return e, thread % lanes, e < nworld


@wp.func(inline=True)
def level_range(m: ModelArrays, k: int, lane: int, lanes: int, active: bool, leaves_first: bool):
    """(start, stop) of the k-th tree level's entries for `lane` (`for i in range(start, stop,
    lanes)`, then `level_body`): levels root first, or leaves first. With one lane the first
    "level" holds every body and the others none: index order has parents first, and walking it
    the way a serial loop does costs a CPU less than the level lists (11 % of the kinematics)."""
    if lanes == 1:
        if k == 0 and active:
            return 0, m.nbody
        return 0, 0
    level = k
    if leaves_first:
        level = m.nlevel - 1 - k
    lo = m.level_adr[level]
    return lo + lane, stop(m.level_adr[level + 1], lo, active)


@wp.func(inline=True)
def level_body(m: ModelArrays, i: int, lanes: int, leaves_first: bool):
    """The body at entry i of a `level_range`."""
    if lanes > 1:
        return m.level_body[i]
    if leaves_first:
        return m.nbody - 1 - i
    return i


@wp.func(inline=True)
def stop(hi: int, lo: int, active: bool):
    """The end of a range a thread walks: `hi`, or `lo` (nothing) for a thread with no world."""
    if active:
        return hi
    return lo
