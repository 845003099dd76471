#!/usr/bin/env python3
"""Writes the long sculpting trace of docs/performance.md's realtime runs: the 8 mm tool
lowered into the `block` generator's clay (128^3, face at z = 63.5) and circling at
20 mm/s on a 15 mm radius, 0.1 mm deeper each lap so it keeps sculpting.

Usage: scripts/make_circle_trace.py OUT.csv [SECONDS]   (default 180)
"""
import math
import sys


def main():
    if len(sys.argv) not in (2, 3):
        sys.exit(__doc__)
    seconds = float(sys.argv[2]) if len(sys.argv) == 3 else 180.0
    rate_hz, radius_mm, speed_mm_s, tool_radius_mm = 1000, 15.0, 20.0, 4.0
    with open(sys.argv[1], "w") as out:
        out.write("t,x,y,z\n")
        for k in range(int(seconds * rate_hz) + 1):
            t = k / rate_hz
            if t < 0.5:  # from 4 mm above the face to 1.5 mm into it
                depth_mm, angle = -4.0 + 5.5 * t / 0.5, 0.0
            else:
                angle = (t - 0.5) * speed_mm_s / radius_mm
                depth_mm = 1.5 + 0.1 * angle / (2 * math.pi)
            z = 63.5 + tool_radius_mm - depth_mm
            out.write(f"{t:.4f},{64 + radius_mm * math.cos(angle):.5f},"
                      f"{64 + radius_mm * math.sin(angle):.5f},{z:.5f}\n")


if __name__ == "__main__":
    main()
