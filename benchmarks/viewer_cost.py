"""What the live page costs training: PPO epochs with no viewer, with the page served but no
browser connected, and with a page connected, interleaved in rounds.

    python benchmarks/viewer_cost.py [--task Ant] [--rounds 5] [--epochs 4]

The task and the rl_games agent are built as `myriad train` builds them (the CPU profile on a
CPU); each round runs `--epochs` whole epochs (rollout and update) per variant, the variants in
turn, each first, second and third in turn, so that the machine's drift falls on all alike. The
connected page is a websocket client speaking viser's protocol (what a browser tab does, without
drawing: that happens on the viewer's machine, not the trainer's). Prints the median env-steps/s
of each variant, its ratio to no viewer, and the middle half of that variant's rounds; and the CPU
time the viewer's own threads used while a page was connected (from /proc: immune to the
machine's drift, though not to what the threads cost the others by holding the GIL).
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import msgspec
import viser
from websockets.sync.client import connect


def open_page(url: str):
    """A websocket client that counts as a page (it gives viser's protocol version, then a first
    camera), drawing nothing; the tests use it too."""
    ws = connect(url.replace("http", "ws"), max_size=None,
                 subprotocols=[f"viser-v{viser.__version__}"])
    ws.send(msgspec.msgpack.encode(dict(
        type="ViewerCameraMessage", wxyz=[1.0, 0.0, 0.0, 0.0], position=[3.0, 3.0, 3.0],
        fov=1.0, near=0.01, far=100.0, image_height=480, image_width=640,
        look_at=[0.0, 0.0, 0.0], up_direction=[0.0, 0.0, 1.0])))
    return ws


def thread_cpu_s(tids) -> float:
    """CPU seconds (user + system) the threads `tids` of this process have used."""
    tick = os.sysconf("SC_CLK_TCK")
    total = 0
    for tid in tids:
        try:
            with open(f"/proc/self/task/{tid}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
            total += int(fields[11]) + int(fields[12])      # utime, stime
        except FileNotFoundError:                           # the thread has ended
            pass
    return total / tick


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", default="Ant")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--epochs", type=int, default=4, help="epochs per variant per round")
    parser.add_argument("--fps", type=float, default=None, help="the page's frame rate "
                        "(default: the viewer's)")
    parser.add_argument("--budget", type=float, default=None, help="the share of one core the "
                        "drawing may take (default: what `myriad train viewer=web` gives it)")
    args = parser.parse_args()
    if args.rounds < 2:
        parser.error(f"--rounds {args.rounds}: at least 2 (the spread between rounds is printed)")

    import threading

    from myriad.viewer import Viewer
    from myriad.viewer.web import TRAINING_BUDGET
    from update_floor import training_agent

    task, agent, _, epoch = training_agent([f"task={args.task}", "device=cpu"])

    def epochs() -> float:
        start = time.perf_counter()
        for _ in range(args.epochs):
            epoch()
        return task.num_envs * agent.horizon_length * args.epochs / (time.perf_counter() - start)

    def drain(ws, stop):                         # a page reads what it is sent
        while not stop.is_set():
            try:
                ws.recv(timeout=0.1)
            except TimeoutError:
                pass
            except Exception:
                return

    pages = []                                   # (frames drawn, seconds) with a page
    viewer_cpu = []                              # the viewer's threads' CPU s per wall s

    def variant(name: str) -> float:
        if name == "no viewer":
            return epochs()
        before = {t.native_id for t in threading.enumerate()}
        options = dict(budget=TRAINING_BUDGET if args.budget is None else args.budget)
        if args.fps is not None:
            options["fps"] = args.fps
        with Viewer(task.envs, port=0, **options) as viewer:
            # the viewer's threads: its drawing thread and viser's server
            ours = {t.native_id for t in threading.enumerate()} - before
            if name == "served, no page":
                return epochs()
            ws, stop = open_page(viewer.url), threading.Event()
            reader = threading.Thread(target=drain, args=(ws, stop), daemon=True)
            reader.start()
            started, cpu = time.perf_counter(), thread_cpu_s(ours)
            rate = epochs()
            wall = time.perf_counter() - started
            pages.append((viewer.frames_drawn, wall))
            viewer_cpu.append((thread_cpu_s(ours) - cpu) / wall)
            stop.set()
            ws.close()
            reader.join()
            return rate

    epochs()                                     # warm-up
    names = ["no viewer", "served, no page", "a page connected"]
    rates = {name: [] for name in names}
    for r in range(args.rounds):                 # each variant first, second, third in turn
        for name in names[r % 3:] + names[:r % 3]:
            rates[name].append(variant(name))
    assert all(frames > 0 for frames, _ in pages), "the page was drawn"
    frames_per_s = sum(f for f, _ in pages) / sum(s for _, s in pages)
    ref = statistics.median(rates["no viewer"])
    print(f"{args.task}, {task.num_envs} envs, {args.rounds} rounds of {args.epochs} "
          f"epochs per variant (env-steps/s, median); page at {frames_per_s:.0f} frames/s:")
    print("| variant | env-steps/s | against no viewer | middle half of the rounds |")
    print("|---|---|---|---|")
    for name, values in rates.items():
        median = statistics.median(values)
        q1, _, q3 = statistics.quantiles(values, n=4)
        print(f"| {name} | {median:,.0f} | {median / ref:.3f} | {q1:,.0f} - {q3:,.0f} |")
    used = statistics.median(viewer_cpu)
    print(f"the viewer's threads (drawing, viser's server) with a page connected: {used:.3f} CPU "
          f"seconds per second, median: {used / os.cpu_count():.1%} of the {os.cpu_count()} "
          "cores")


if __name__ == "__main__":
    main()
