#!/usr/bin/env python3
"""sphere.py OUT_DIR

Writes OUT_DIR/sphere.obj, sphere.mtl and sphere.toml: a closed sphere of radius 1 (64 x 32
segments, faces and normals inward, albedo 0.5) with a point light at its centre and the camera
inside, 64x64. Every point of it sees the same direct radiance, so its indirect image (one bounce)
is exactly the albedo times its direct image: a scene whose answer is known, where every surface
orientation occurs. Python's standard library only."""
import math
import os
import sys

if len(sys.argv) != 2:
    sys.exit(__doc__)
out = sys.argv[1]
os.makedirs(out, exist_ok=True)
nu, nv = 64, 32
v, n, f = [], [], []
for j in range(nv + 1):
    th = math.pi * j / nv
    for i in range(nu):
        ph = 2 * math.pi * i / nu
        p = (math.sin(th) * math.cos(ph), math.cos(th), math.sin(th) * math.sin(ph))
        v.append(p)
        n.append(tuple(-c for c in p))


def at(i, j):
    return j * nu + i % nu + 1


for j in range(nv):
    for i in range(nu):
        a, b, c, d = at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)
        if j > 0:
            f.append((a, c, b))
        if j < nv - 1:
            f.append((a, d, c))
with open(os.path.join(out, "sphere.obj"), "w") as o:
    o.write("mtllib sphere.mtl\nusemtl grey\n")
    o.writelines("v %f %f %f\n" % p for p in v)
    o.writelines("vn %f %f %f\n" % p for p in n)
    o.writelines("f %d//%d %d//%d %d//%d\n" % (a, a, b, b, c, c) for a, b, c in f)
open(os.path.join(out, "sphere.mtl"), "w").write("newmtl grey\nKd 0.5 0.5 0.5\nKs 0 0 0\n")
open(os.path.join(out, "sphere.toml"), "w").write(
    """[mesh]
obj = "sphere.obj"
[camera]
eye = [0.0, 0.0, 0.3]
target = [0.0, 0.0, -1.0]
up = [0.0, 1.0, 0.0]
fov_y_deg = 60.0
width = 64
height = 64
[[lights]]
type = "point"
position = [0.0, 0.0, 0.0]
intensity = [1.0, 1.0, 1.0]
"""
)
