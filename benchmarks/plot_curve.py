"""Learning curve of a training run as an SVG (no plotting library needed).

    python benchmarks/plot_curve.py runs/bench_cpu_ant/progress.csv docs/img/ant_cpu_curve.svg \
        --title "Ant, 2-core CPU" --target 3000

x: wall-clock minutes; y: mean episode reward (rl_games' mean over the last finished episodes),
or another column of progress.csv (`--column consecutive_successes` for the hand tasks).
"""

import argparse
import csv
import math


def nice_step(span: float, ticks: int = 5) -> float:
    raw = span / ticks
    mag = 10 ** math.floor(math.log10(raw))
    return min((m * mag for m in (1, 2, 2.5, 5, 10) if m * mag >= raw), default=10 * mag)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("csv")
    ap.add_argument("svg")
    ap.add_argument("--title", default="")
    ap.add_argument("--target", type=float, default=None, help="draw a dashed target line")
    ap.add_argument("--column", default="mean_reward", help="the progress.csv column to draw")
    args = ap.parse_args()

    points = []
    with open(args.csv) as f:
        for row in csv.DictReader(f):
            if row.get(args.column):
                points.append((float(row["wall_s"]) / 60.0, float(row[args.column])))
    if not points:
        raise SystemExit(f"{args.csv}: no epoch with a value of {args.column} yet")
    label = "mean episode reward" if args.column == "mean_reward" else args.column.replace("_", " ")
    stride = max(1, len(points) // 400)          # a few hundred points draw the same curve
    points = points[::stride] + ([points[-1]] if (len(points) - 1) % stride else [])
    W, H, L, R, T, B = 640, 360, 60, 20, 36, 44
    x_max = max(p[0] for p in points)
    y_lo = min(0.0, min(p[1] for p in points))
    y_hi = max([p[1] for p in points] + ([args.target] if args.target else []))
    y_hi += 0.05 * (y_hi - y_lo)

    def sx(x):
        return L + (W - L - R) * x / x_max

    def sy(y):
        return H - B - (H - T - B) * (y - y_lo) / (y_hi - y_lo)

    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" '
           'font-family="sans-serif" font-size="12">',
           f'<rect width="{W}" height="{H}" fill="white"/>',
           f'<text x="{W / 2}" y="20" text-anchor="middle" font-size="14">{args.title}</text>']
    step = nice_step(y_hi - y_lo)
    y = math.ceil(y_lo / step) * step
    while y <= y_hi:
        out.append(f'<line x1="{L}" x2="{W - R}" y1="{sy(y):.1f}" y2="{sy(y):.1f}" stroke="#ddd"/>')
        out.append(f'<text x="{L - 6}" y="{sy(y) + 4:.1f}" text-anchor="end">{y:g}</text>')
        y += step
    step = nice_step(x_max)
    x = 0.0
    while x <= x_max + 1e-9:
        out.append(f'<text x="{sx(x):.1f}" y="{H - B + 16}" text-anchor="middle">{x:g}</text>')
        x += step
    out.append(f'<text x="{(L + W - R) / 2}" y="{H - 8}" text-anchor="middle">wall-clock minutes'
               '</text>')
    out.append(f'<text x="14" y="{(T + H - B) / 2}" text-anchor="middle" '
               f'transform="rotate(-90 14 {(T + H - B) / 2})">{label}</text>')
    if args.target:
        out.append(f'<line x1="{L}" x2="{W - R}" y1="{sy(args.target):.1f}" '
                   f'y2="{sy(args.target):.1f}" stroke="#c33" stroke-dasharray="6 4"/>')
        out.append(f'<text x="{W - R - 4}" y="{sy(args.target) - 5:.1f}" text-anchor="end" '
                   f'fill="#c33">{args.target:g}</text>')
    path = " ".join(f"{sx(x):.1f},{sy(y):.1f}" for x, y in points)
    out.append(f'<polyline points="{path}" fill="none" stroke="#1f6fb4" stroke-width="2"/>')
    out.append(f'<line x1="{L}" x2="{L}" y1="{T}" y2="{H - B}" stroke="black"/>')
    out.append(f'<line x1="{L}" x2="{W - R}" y1="{H - B}" y2="{H - B}" stroke="black"/>')
    out.append("</svg>")
    with open(args.svg, "w") as f:
        f.write("\n".join(out) + "\n")
    print(f"wrote {args.svg}: {len(points)} points, last {args.column} {points[-1][1]:.2f} at "
          f"{points[-1][0]:.1f} min")


if __name__ == "__main__":
    main()
