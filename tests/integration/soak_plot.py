#!/usr/bin/env python3
"""The soak's curves as an SVG: resident memory, descriptors and threads per role, and the run
folder's size, against time (standard library only; rsvg-convert makes the PNG).

  soak_plot.py SAMPLES OUT.svg
"""
import csv
import sys

rows = list(csv.DictReader(open(sys.argv[1])))
roles = ["broker", "learner", "actor-0", "actor-1"]
colours = {"broker": "#1f77b4", "learner": "#d62728", "actor-0": "#2ca02c", "actor-1": "#9467bd",
           "run": "#555555"}
panels = [("resident memory (MB)", "rss_kb", 1 / 1024), ("open descriptors", "fds", 1),
          ("threads", "threads", 1), ("run folder (MB)", "run_bytes", 1e-6)]
W, H, M = 900, 190, 55
t_max = max(int(r["t"]) for r in rows) or 1
stall = [int(r["t"]) for r in rows if r["phase"] == "stall"]
out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H * len(panels) + 30}" '
       f'font-family="sans-serif" font-size="11"><rect width="100%" height="100%" fill="white"/>']
for i, (title, key, scale) in enumerate(panels):
    y0 = i * H + 20
    series = {}
    for role in (["run"] if key == "run_bytes" else roles):
        owner = "learner" if role == "run" else role  # the folder's size is on the learner's rows
        points = [(int(r["t"]), float(r[key]) * scale, r["life"]) for r in rows
                  if r["role"] == owner]
        series[role] = points
    values = [v for pts in series.values() for _, v, _ in pts] or [0, 1]
    lo, hi = 0, max(values) * 1.1 or 1
    x = lambda t: M + (W - M - 20) * t / t_max
    y = lambda v: y0 + H - 35 - (H - 55) * (v - lo) / (hi - lo)
    out.append(f'<text x="{M}" y="{y0 + 10}" font-weight="bold">{title}</text>')
    out.append(f'<line x1="{M}" y1="{y(0)}" x2="{W - 20}" y2="{y(0)}" stroke="#999"/>')
    out.append(f'<text x="{M - 5}" y="{y(hi / 1.1) + 4}" text-anchor="end">{hi / 1.1:.0f}</text>')
    out.append(f'<text x="{M - 5}" y="{y(0) + 4}" text-anchor="end">0</text>')
    if stall:
        out.append(f'<rect x="{x(min(stall))}" y="{y0 + 15}" width="{max(2, x(max(stall)) - x(min(stall)))}" '
                   f'height="{H - 50}" fill="#f4e2b0" opacity="0.6"/>')
    for role, pts in series.items():
        by_life = {}
        for t, v, life in pts:
            by_life.setdefault(life, []).append((t, v))
        for life_pts in by_life.values():  # a line per process life: a restart starts a new one
            path = " ".join(f"{x(t):.1f},{y(v):.1f}" for t, v in life_pts)
            out.append(f'<polyline points="{path}" fill="none" stroke="{colours[role]}" stroke-width="1.5"/>')
    out.append(f'<text x="{W - 20}" y="{y0 + H - 20}" text-anchor="end">time (min), '
               f'{t_max / 60:.0f} in all; shaded: the learner stopped</text>')
for j, role in enumerate(roles):
    out.append(f'<text x="{M + 90 * j}" y="{H * len(panels) + 20}" fill="{colours[role]}">{role}</text>')
out.append("</svg>")
open(sys.argv[2], "w").write("\n".join(out))
