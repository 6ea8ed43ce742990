#!/usr/bin/env python3
"""Shade time against the character count from `bench` CSVs of the crowd scene, as an SVG (log-log).

Usage: tools/plots/crowd_cost.py OUT.svg BENCH.csv [BENCH.csv ...]
Each technique spec of the CSVs is one line; the character count is read from the scene name (crowd:count=N...).
Shade time = the sum of the `shade/*` passes' medians (the tile pass included). Standard library only.
"""
import csv
import math
import re
import sys
from collections import defaultdict


def read(paths):
    series = defaultdict(dict)  # technique -> count -> shade ms
    for path in paths:
        with open(path, newline="") as f:
            for row in csv.DictReader(f):
                m = re.search(r"count=(\d+)", row["scene"])
                if not m or not row["pass"].startswith("shade/"):
                    continue
                n = int(m.group(1))
                series[row["technique"]][n] = series[row["technique"]].get(n, 0.0) + float(row["median_ms"])
    return series


def svg(series, width=760, height=400, margin=60, legend=150):
    xs = sorted({n for s in series.values() for n in s})
    ys = [v for s in series.values() for v in s.values() if v > 0]
    if not xs or not ys:
        raise SystemExit("no crowd rows with shade passes in the CSVs")
    lx0, lx1 = math.log10(min(xs)), math.log10(max(xs)) + 1e-9
    ly0, ly1 = math.floor(math.log10(min(ys))), math.ceil(math.log10(max(ys)))
    px = lambda n: margin + (math.log10(n) - lx0) / (lx1 - lx0) * (width - 2 * margin - legend)
    py = lambda v: height - margin - (math.log10(v) - ly0) / (ly1 - ly0) * (height - 2 * margin)
    colours = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#7f7f7f"]
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" font-family="sans-serif" font-size="12">',
           f'<rect width="{width}" height="{height}" fill="white"/>']
    for d in range(ly0, ly1 + 1):
        y = py(10 ** d)
        out.append(f'<line x1="{margin}" y1="{y:.1f}" x2="{width - margin - legend}" y2="{y:.1f}" stroke="#ddd"/>')
        out.append(f'<text x="{margin - 6}" y="{y + 4:.1f}" text-anchor="end">{10 ** d:g}</text>')
    for n in xs:
        x = px(n)
        out.append(f'<line x1="{x:.1f}" y1="{margin}" x2="{x:.1f}" y2="{height - margin}" stroke="#eee"/>')
        out.append(f'<text x="{x:.1f}" y="{height - margin + 16}" text-anchor="middle">{n}</text>')
    out.append(f'<text x="{(width - legend) / 2}" y="{height - 14}" text-anchor="middle">characters</text>')
    out.append(f'<text x="16" y="{height / 2}" text-anchor="middle" transform="rotate(-90 16 {height / 2})">shade ms (log)</text>')
    for i, (name, s) in enumerate(sorted(series.items())):
        c = colours[i % len(colours)]
        pts = " ".join(f"{px(n):.1f},{py(v):.1f}" for n, v in sorted(s.items()) if v > 0)
        out.append(f'<polyline points="{pts}" fill="none" stroke="{c}" stroke-width="2"/>')
        out.append(f'<text x="{width - margin - legend + 10}" y="{margin + 14 * i}" fill="{c}">{name}</text>')
    out.append("</svg>")
    return "\n".join(out) + "\n"


if __name__ == "__main__":
    if len(sys.argv) < 3:
        raise SystemExit(__doc__)
    with open(sys.argv[1], "w") as f:
        f.write(svg(read(sys.argv[2:])))
