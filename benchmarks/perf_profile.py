"""Where a CPU step spends its time, per compiled function, with Linux `perf`.

    python benchmarks/perf_profile.py --model humanoid [--envs 1024] [--seconds 8] [--lines]

Warp loads each module's CPU object into memory with its own linker, so `perf` sees the
kernels as anonymous code. This script steps a model on one thread, writes the symbol map
`perf` reads for such code (/tmp/perf-<pid>.map: each function of every loaded engine object,
at the address the linker placed it), runs `perf record` on itself meanwhile, and prints
`perf report`'s table. Functions Warp inlined are counted in their caller; with `--lines` the
samples are also attributed to the kernels' Python source lines (through Warp's generated C++,
compiled with line tables into cache entries of their own). The load address of an object is
found from one exported kernel entry: Warp's CPU objects hold all their code in one section
(`.ltext`), so one offset serves every symbol. Needs `perf` on the
PATH and sampling allowed (the `cpu-clock` software event works where hardware counters are
not exposed). Isaac Gym timing and fresh random controls every step, as `step_rate.py`.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import time

import torch
import warp as wp

import myriad
from contacts import boxes_xml


def write_perf_map() -> tuple[str, list]:
    """/tmp/perf-<pid>.map with every function symbol of the engine's loaded CPU objects; and
    (load address, size, object path) of each object."""
    from warp._src import context

    lines, objects = [], []
    for name in myriad.physics.runtime.kernel_modules():
        module = wp.get_module(name)
        for module_exec in module.execs.values():
            if not module_exec.device.is_cpu:
                continue
            path = getattr(module_exec, "binary_path", None)
            if not path or not os.path.exists(path):
                continue
            symbols = []
            for line in subprocess.run(["nm", "-S", path], capture_output=True, text=True).stdout.splitlines():
                parts = line.split()
                if len(parts) == 4 and parts[2] in "tTwW":
                    symbols.append((int(parts[0], 16), int(parts[1], 16), parts[3]))
            base = None
            for offset, _, sym in symbols:    # an exported kernel entry gives the load address
                if sym.endswith("_cpu_forward"):
                    address = context.runtime.llvm.wp_lookup(module_exec.handle.encode(), sym.encode())
                    if address:
                        base = address - offset
                        break
            if base is None:
                continue
            objects.append((base, max(o + n for o, n, _ in symbols), path))
            short = name.rsplit(".", 1)[-1]
            lines += [f"{base + offset:x} {size:x} {short}:{demangle(sym)}" for offset, size, sym in symbols]
    path = f"/tmp/perf-{os.getpid()}.map"
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")
    return path, objects


def source_lines(data: str, objects: list, top: int) -> list[str]:
    """Samples per Python source line of the kernels: each sampled address is mapped to its line
    of Warp's generated C++ (addr2line on the object, which --lines builds with debug info),
    whose comments name the Python line it came from."""
    import bisect
    import collections

    ips = subprocess.run(["perf", "script", "-i", data, "-F", "ip"], capture_output=True,
                         text=True).stdout.split()
    starts = sorted(objects)
    per_object = collections.defaultdict(list)
    for ip in ips:
        address = int(ip, 16)
        k = bisect.bisect_right([b for b, _, _ in starts], address) - 1
        if k >= 0 and address < starts[k][0] + starts[k][1]:
            per_object[starts[k][2]].append(address - starts[k][0])
    counts = collections.Counter()
    for path, offsets in per_object.items():
        # -i: the chain of inlined frames; the innermost one in the generated source counts
        out = subprocess.run(["addr2line", "-i", "-a", "-e", path],
                             input="\n".join(f"{o:x}" for o in offsets),
                             capture_output=True, text=True).stdout.splitlines()
        # the debug info names the build's temporary folder: the source sits beside the object
        cpp = os.path.join(os.path.dirname(path), os.path.basename(path).split(".cpu")[0] + ".cpp")
        text = open(cpp).read().splitlines() if os.path.exists(cpp) else []
        frames = []
        for loc in out + ["0x"]:
            if loc.startswith("0x"):
                line = next((f for f in frames if f[0].endswith(".cpp")), None)
                frames = []
                if line is None:
                    counts["(warp builtins outside generated code)"] += 1 if loc != "0x" else 0
                    continue
                n = line[1] - 1
                while 0 <= n < len(text) and "<L " not in text[n] and not text[n].startswith("// /"):
                    n -= 1
                if not (0 <= n < len(text)) or text[n].startswith("// /"):
                    # no Python line: a native function's body, or a function's entry
                    header = text[n + 1] if 0 <= n < len(text) - 1 else ""
                    name = re.search(r"(\w+)\($", header) or re.search(r"(\w+)\(", header)
                    counts[f"(entry or native body of {name.group(1) if name else '?'})"] += 1
                    continue
                origin = re.search(r"//\s*(.*?)\s*<L (\d+)>", text[n])
                func = next((text[k] for k in range(n, -1, -1) if text[k].startswith("// /")), "")
                where = os.path.basename(func.split()[1]).split(":")[0] if func else "?"
                counts[f"{where}:{origin.group(2)}  {origin.group(1)[:90]}"] += 1
            else:
                file, _, number = loc.partition(" ")[0].rpartition(":")
                if number.isdigit():
                    frames.append((file, int(number)))
    total = len(ips)
    return [f"{100 * c / total:6.2f}%  {k}" for k, c in counts.most_common(top)]


def demangle(sym: str) -> str:
    out = subprocess.run(["c++filt", sym], capture_output=True, text=True).stdout.strip()
    return out.split("(")[0] or sym


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--model", default="humanoid", help="ant, humanoid or boxes")
    ap.add_argument("--envs", type=int, default=1024)
    ap.add_argument("--seconds", type=float, default=8.0)
    ap.add_argument("--top", type=int, default=40)
    ap.add_argument("--lines", action="store_true",
                    help="also attribute samples to Python source lines of the kernels (compiles "
                         "the engine with debug info, into its own cache entries)")
    args = ap.parse_args()
    wp.config.log_level = wp.LOG_WARNING
    if args.lines:
        wp.config.cpu_compiler_flags = (wp.config.cpu_compiler_flags or "-march=native") + " -debug-info-kind=line-tables-only -dwarf-version=4"
    torch.set_num_threads(1)
    if args.model == "boxes":
        model, slots = myriad.load_xml(boxes_xml(), "64 boxes"), 512
    else:
        model, slots = myriad.load(myriad.asset_path(f"{args.model}.xml")), 64
    params = myriad.SimParams(dt=1 / 60, substeps=2, position_iterations=4,
                              velocity_iterations=0, contacts_per_env=slots)
    sim = myriad.Simulator(model, num_envs=args.envs, params=params, cpu_threads=1)
    gen = torch.Generator().manual_seed(0)
    for _ in range(20):
        sim.step()
    _, objects = write_perf_map()
    data = f"/tmp/perf-{os.getpid()}.data"
    rec = subprocess.Popen(["perf", "record", "-e", "cpu-clock", "-F", "2000", "-p", str(os.getpid()),
                            "-o", data], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    time.sleep(0.5)
    start, steps = time.perf_counter(), 0
    while time.perf_counter() - start < args.seconds:
        if model.nu:
            sim.ctrl = torch.rand(args.envs, model.nu, generator=gen) * 2 - 1
        sim.step()
        steps += 1
    rate = steps * args.envs / (time.perf_counter() - start)
    rec.send_signal(2)
    rec.wait()
    print(f"{args.model}, {args.envs} envs, one thread: {rate:,.0f} env-steps/s while recording")
    report = subprocess.run(["perf", "report", "-i", data, "--stdio", "--sort", "symbol",
                             "--percent-limit", "0.3"], capture_output=True, text=True).stdout
    rows = [line for line in report.splitlines() if line.strip() and not line.startswith("#")]
    print("\n".join(rows[:args.top]))
    if args.lines:
        print("\nby Python source line of the kernels (share of all samples):")
        print("\n".join(source_lines(data, objects, args.top)))


if __name__ == "__main__":
    main()
