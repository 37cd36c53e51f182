#!/usr/bin/env python3
"""rotate.py OUT_DIR NAME AX AY AZ [--box S]

Writes OUT_DIR/NAME.obj, NAME.toml (and room.mtl): room.obj beside this script (a closed room
[-1, 1]^3 with inward faces, a red and a green wall, a box inside), its camera and its point light,
all rotated as a whole about the origin by AX, then AY, then AZ degrees about x, y and z. The
rotated scene's images are the same images; only the voxel grid's orientation changes.

--box S adds two tiny triangles outside the room at (-S, -S, -S) and (S, S, S): the voxel grid (a
cube around the mesh's bounds) is then [-S, S]^3 whatever the rotation, so a sweep of S moves the
walls through a voxel at a fixed voxel size.
Python's standard library only."""
import math
import os
import shutil
import sys

args = sys.argv[1:]
if len(args) < 5:
    sys.exit(__doc__)
out, name = args[0], args[1]
ax, ay, az = (math.radians(float(a)) for a in args[2:5])
box = float(args[6]) if len(args) >= 7 and args[5] == "--box" else None


def rx(a):
    c, s = math.cos(a), math.sin(a)
    return [[1, 0, 0], [0, c, -s], [0, s, c]]


def ry(a):
    c, s = math.cos(a), math.sin(a)
    return [[c, 0, s], [0, 1, 0], [-s, 0, c]]


def rz(a):
    c, s = math.cos(a), math.sin(a)
    return [[c, -s, 0], [s, c, 0], [0, 0, 1]]


def mul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


m = mul(rz(az), mul(ry(ay), rx(ax)))


def rot(p):
    return [sum(m[i][j] * p[j] for j in range(3)) for i in range(3)]


here = os.path.dirname(os.path.abspath(__file__))
os.makedirs(out, exist_ok=True)
shutil.copy(os.path.join(here, "room.mtl"), os.path.join(out, "room.mtl"))
lines, count = [], 0
for line in open(os.path.join(here, "room.obj")):
    if line.startswith("v "):
        lines.append("v %.9f %.9f %.9f" % tuple(rot([float(w) for w in line.split()[1:4]])))
        count += 1
    else:
        lines.append(line.rstrip("\n"))
if box is not None:
    lines.append("usemtl white")
    for c in (-box, box):
        d = -0.004 if c > 0 else 0.004
        lines += ["v %r %r %r" % (c, c, c), "v %r %r %r" % (c + d, c, c), "v %r %r %r" % (c, c + d, c + d)]
        lines.append("f %d %d %d" % (count + 1, count + 2, count + 3))
        count += 3
open(os.path.join(out, name + ".obj"), "w").write("\n".join(lines) + "\n")
v = lambda p: "[%r, %r, %r]" % tuple(p)
open(os.path.join(out, name + ".toml"), "w").write(
    f"""[mesh]
obj = "{name}.obj"
[camera]
eye = {v(rot([0.0, 0.2, 0.95]))}
target = {v(rot([0.0, -0.2, -1.0]))}
up = {v(rot([0.0, 1.0, 0.0]))}
fov_y_deg = 70.0
width = 64
height = 64
[[lights]]
type = "point"
position = {v(rot([0.3, 0.6, 0.2]))}
intensity = [2.0, 2.0, 2.0]
"""
)
