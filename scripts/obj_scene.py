#!/usr/bin/env python3
"""Writes the OBJ test scene `gallery` (issue 15: the planner's rows on an
OBJ scene loaded with `--scene file.obj`): a mirror floor, a chrome sphere,
a glossy torus, a mirror panel, colored boxes and columns and a back wall,
with an MTL file for the diffuse colors. Deterministic (no randomness), so
the checked-in `scenes/gallery.obj` is this script's output:

    python3 scripts/obj_scene.py scenes/gallery.obj

Report it with the reflective objects named (name part:specular:roughness):

    cargo run --release -- report --scene scenes/gallery.obj \\
        --reflective mirror:0.9:0 --reflective chrome:0.9:0 \\
        --reflective glossy:0.8:0.25
"""
import math
import os
import sys

out = sys.argv[1] if len(sys.argv) > 1 else "scenes/gallery.obj"
mtl_name = os.path.splitext(os.path.basename(out))[0] + ".mtl"
lines = ["# refl OBJ test scene (scripts/obj_scene.py); y up", f"mtllib {mtl_name}"]
count = 0  # vertices written so far
tris = 0


def obj(name, material, verts, faces):
    """One object: `verts` as (x, y, z), `faces` as index triples (0-based)."""
    global count, tris
    lines.append(f"o {name}")
    lines.append(f"usemtl {material}")
    for v in verts:
        lines.append("v %.6f %.6f %.6f" % v)
    for f in faces:
        lines.append("f %d %d %d" % tuple(count + i + 1 for i in f))
    count += len(verts)
    tris += len(faces)


def quad(name, material, a, b, c, d):
    obj(name, material, [a, b, c, d], [(0, 1, 2), (0, 2, 3)])


def box(name, material, center, size):
    (cx, cy, cz), (sx, sy, sz) = center, size
    v = [
        (cx + dx * sx / 2, cy + dy * sy / 2, cz + dz * sz / 2)
        for dx in (-1, 1)
        for dy in (-1, 1)
        for dz in (-1, 1)
    ]
    # Corner index = 4 * (dx > 0) + 2 * (dy > 0) + (dz > 0); outward faces.
    f = [
        (0, 1, 3), (0, 3, 2),  # -x
        (4, 6, 7), (4, 7, 5),  # +x
        (0, 4, 5), (0, 5, 1),  # -y
        (2, 3, 7), (2, 7, 6),  # +y
        (0, 2, 6), (0, 6, 4),  # -z
        (1, 5, 7), (1, 7, 3),  # +z
    ]
    obj(name, material, v, f)


def grid_faces(nu, nv, wrap_u, wrap_v):
    """Two triangles per cell of a (nu x nv) vertex grid (u major)."""
    f = []
    cu = nu if wrap_u else nu - 1
    cv = nv if wrap_v else nv - 1
    for i in range(cu):
        for j in range(cv):
            a = i * nv + j
            b = ((i + 1) % nu) * nv + j
            c = ((i + 1) % nu) * nv + (j + 1) % nv
            d = i * nv + (j + 1) % nv
            f += [(a, b, c), (a, c, d)]
    return f


def sphere(name, material, center, r, nu=64, nv=33):
    cx, cy, cz = center
    v = []
    for i in range(nu):
        phi = 2 * math.pi * i / nu
        for j in range(nv):
            th = math.pi * j / (nv - 1)
            v.append((cx + r * math.sin(th) * math.cos(phi), cy + r * math.cos(th),
                      cz - r * math.sin(th) * math.sin(phi)))
    obj(name, material, v, grid_faces(nu, nv, True, False))


def torus(name, material, center, big, small, nu=72, nv=24):
    """Upright torus (axis along z)."""
    cx, cy, cz = center
    v = []
    for i in range(nu):
        a = 2 * math.pi * i / nu
        for j in range(nv):
            b = 2 * math.pi * j / nv
            rr = big + small * math.cos(b)
            v.append((cx + rr * math.cos(a), cy + rr * math.sin(a), cz + small * math.sin(b)))
    obj(name, material, v, grid_faces(nu, nv, True, True))


def cylinder(name, material, base, r, h, n=32):
    bx, by, bz = base
    v = []
    for i in range(n):
        a = 2 * math.pi * i / n
        v += [(bx + r * math.cos(a), by, bz - r * math.sin(a)),
              (bx + r * math.cos(a), by + h, bz - r * math.sin(a))]
    f = []
    for i in range(n):
        a0, a1 = 2 * i, 2 * i + 1
        b0, b1 = 2 * ((i + 1) % n), 2 * ((i + 1) % n) + 1
        f += [(a0, b0, b1), (a0, b1, a1)]
    top = len(v)
    v.append((bx, by + h, bz))
    for i in range(n):
        f.append((top, 2 * i + 1, 2 * ((i + 1) % n) + 1))
    obj(name, material, v, f)


quad("mirror_floor", "steel", (-6, 0, -6), (-6, 0, 6), (6, 0, 6), (6, 0, -6))
quad("back_wall", "brick", (-6, 0, -6), (6, 0, -6), (6, 4, -6), (-6, 4, -6))
quad("side_wall", "sea", (-6, 0, 6), (-6, 0, -6), (-6, 4, -6), (-6, 4, 6))
# A mirror panel facing the scene (planar, upright, tilted 30 degrees).
c, s = math.cos(math.radians(30)), math.sin(math.radians(30))
px, pz = 4.0, -3.0
quad("mirror_panel", "steel", (px - 1.2 * c, 0.2, pz - 1.2 * s), (px + 1.2 * c, 0.2, pz + 1.2 * s),
     (px + 1.2 * c, 2.6, pz + 1.2 * s), (px - 1.2 * c, 2.6, pz - 1.2 * s))
sphere("chrome_sphere", "steel", (1.5, 1.0, 0.5), 1.0)
torus("glossy_torus", "gold", (-2.0, 1.4, 0.0), 1.0, 0.35)
box("box_red", "red", (-0.5, 0.5, -2.5), (1.0, 1.0, 1.0))
box("box_green", "green", (2.8, 0.4, 2.5), (0.8, 0.8, 1.4))
box("box_blue", "blue", (-3.8, 0.75, 3.0), (1.2, 1.5, 0.9))
for k, (x, z) in enumerate([(-4.5, -4.5), (4.5, -4.5), (-4.5, 4.5), (4.5, 4.5)]):
    cylinder(f"column_{k}", "stone", (x, 0.0, z), 0.3, 3.0)

with open(out, "w") as f:
    f.write("\n".join(lines) + "\n")
mtl = {
    "steel": (0.6, 0.6, 0.6), "brick": (0.7, 0.3, 0.2), "sea": (0.2, 0.4, 0.7),
    "gold": (0.8, 0.6, 0.2), "red": (0.8, 0.1, 0.1), "green": (0.1, 0.7, 0.2),
    "blue": (0.15, 0.2, 0.8), "stone": (0.75, 0.72, 0.65),
}
with open(os.path.join(os.path.dirname(out) or ".", mtl_name), "w") as f:
    for name, (r, g, b) in mtl.items():
        f.write(f"newmtl {name}\nKd {r} {g} {b}\n\n")
print(f"{out}: {tris} triangles, {count} vertices")
