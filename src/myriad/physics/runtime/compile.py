"""Compiling and loading the engine's Warp kernels, with progress for a cold cache.

Warp compiles a module's kernels for a device the first time they are needed and caches the
binaries (`~/.cache/warp`): later runs load them in milliseconds, but a first run on a machine
spends tens of seconds compiling. `load_kernels` does that work up front and, when a module
takes longer than a moment, says which one it is compiling and how long it took, so that a first
run never looks hung.
"""

from __future__ import annotations

import pkgutil
import threading
import time

import warp as wp


def kernel_modules() -> list[str]:
    """Names of the engine's modules (myriad.physics and below)."""
    from ... import physics

    return [m.name for m in pkgutil.walk_packages(physics.__path__, physics.__name__ + ".")]


def configure_modules() -> None:
    """Build options of every engine module, set before anything compiles: no adjoint (backward)
    kernels, since nothing differentiates the engine; that halves a cold compile."""
    import importlib

    for name in kernel_modules():
        importlib.import_module(name)
        wp.set_module_options({"enable_backward": False}, name)


def load_kernels(device, report=print, notice_after_s: float = 1.0) -> float:
    """Compile (or load from the cache) every engine kernel for `device`; returns the seconds
    taken. A module still loading after `notice_after_s` is announced through `report`, and its
    time reported when done."""
    import importlib

    device = wp.get_device(str(device))
    start = time.perf_counter()
    compiled = 0
    for name in kernel_modules():
        importlib.import_module(name)
        if not wp.get_module(name).kernels:     # helpers and structs load with their users
            continue
        t0 = time.perf_counter()
        announced = threading.Event()

        def announce(name=name):
            announced.set()
            report(f"  compiling {name} for {device} (first run on this machine; cached "
                   "afterwards) ...")
        timer = threading.Timer(notice_after_s, announce)
        timer.start()
        try:
            wp.load_module(name, device=device)
        finally:
            timer.cancel()
        if announced.is_set():
            compiled += 1
            report(f"    done in {time.perf_counter() - t0:.1f} s")
    total = time.perf_counter() - start
    if compiled:
        report(f"  physics kernels ready for {device} in {total:.1f} s")
    return total
