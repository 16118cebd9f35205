#!/usr/bin/env python3
"""Draws bench/scaling.sh's CSV as an SVG: wall and CPU time and peak memory against the drive's frames
(Pandar64 at 0.2 deg) and, on the right, against points per sweep (1000-frame drives). No
plotting library: the SVG is written by hand. Usage: plot_scaling.py scaling.csv out.svg"""
import csv
import sys

W, H, PAD = 360, 240, 48


def panel(x0, rows, key, xlabel, title):
    if not rows:
        return [f'<text x="{x0 + W / 2}" y="{H / 2}" text-anchor="middle">{title}: not measured</text>']
    xs = [float(r[key]) for r in rows]
    walls = [float(r["wall_s"]) for r in rows]
    cpus = [float(r["cpu_s"]) for r in rows]
    mems = [float(r["peak_mb"]) for r in rows]
    xmax, tmax, mmax = max(xs) * 1.05, max(walls + cpus + [5.0]) * 1.15, max(mems + [500.0]) * 1.15
    px = lambda v: x0 + PAD + (W - 2 * PAD) * v / xmax
    pt = lambda v: H - PAD + -(H - 2 * PAD) * v / tmax
    pm = lambda v: H - PAD + -(H - 2 * PAD) * v / mmax
    out = [f'<text x="{x0 + W / 2}" y="18" text-anchor="middle" font-weight="bold">{title}</text>',
           f'<line x1="{px(0)}" y1="{H - PAD}" x2="{x0 + W - PAD}" y2="{H - PAD}" stroke="black"/>',
           f'<line x1="{px(0)}" y1="{PAD}" x2="{px(0)}" y2="{H - PAD}" stroke="#1f5fbf"/>',
           f'<line x1="{x0 + W - PAD}" y1="{PAD}" x2="{x0 + W - PAD}" y2="{H - PAD}" stroke="#c0392b"/>',
           f'<text x="{x0 + W / 2}" y="{H - 10}" text-anchor="middle">{xlabel}</text>',
           f'<text x="{x0 + 12}" y="{H / 2}" fill="#1f5fbf" transform="rotate(-90 {x0 + 12} {H / 2})" text-anchor="middle">wall s (solid), CPU s (dashed)</text>',
           f'<text x="{x0 + W - 8}" y="{H / 2}" fill="#c0392b" transform="rotate(90 {x0 + W - 8} {H / 2})" text-anchor="middle">peak MB</text>']
    for frac in (0.0, 0.5, 1.0):
        out.append(f'<text x="{px(0) - 4}" y="{pt(tmax * frac / 1.15) + 4}" text-anchor="end" fill="#1f5fbf">{tmax * frac / 1.15:.0f}</text>')
        out.append(f'<text x="{x0 + W - PAD + 4}" y="{pm(mmax * frac / 1.15) + 4}" fill="#c0392b">{mmax * frac / 1.15:.0f}</text>')
    for v in xs:
        out.append(f'<text x="{px(v)}" y="{H - PAD + 14}" text-anchor="middle">{v:.0f}</text>')
    out.append(f'<line x1="{px(0)}" y1="{pm(500)}" x2="{x0 + W - PAD}" y2="{pm(500)}" stroke="#c0392b" stroke-dasharray="3,3"/>')
    for series, y, colour, dash in ((walls, pt, "#1f5fbf", ""), (cpus, pt, "#1f5fbf", "6,3"), (mems, pm, "#c0392b", "")):
        pts = " ".join(f"{px(a)},{y(b)}" for a, b in sorted(zip(xs, series)))
        out.append(f'<polyline points="{pts}" fill="none" stroke="{colour}" stroke-width="2" stroke-dasharray="{dash}"/>')
        out += [f'<circle cx="{px(a)}" cy="{y(b)}" r="3" fill="{colour}"/>' for a, b in zip(xs, series)]
    return out


def main():
    rows = list(csv.DictReader(open(sys.argv[1])))
    by_frames = [r for r in rows if r["drive"].startswith("f") or r["drive"] == "drive"]
    by_points = [r for r in rows if r["drive"].startswith("p") or r["drive"] == "drive"]
    body = panel(0, by_frames, "frames", "frames in the drive (Pandar64, 0.2 deg)", "cost vs drive length")
    body += panel(W, by_points, "points_per_sweep", "points per sweep (1000+ frames)", "cost vs sweep size")
    svg = (f'<svg xmlns="http://www.w3.org/2000/svg" width="{2 * W}" height="{H}" font-family="sans-serif" font-size="11">'
           + '<rect width="100%" height="100%" fill="white"/>' + "".join(body) + "</svg>\n")
    open(sys.argv[2], "w").write(svg)


if __name__ == "__main__":
    main()
