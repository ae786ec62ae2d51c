#!/usr/bin/env python3
"""Writes the textures of raylab's bundled scenes (CC0; needs Pillow). Run: python3 make_textures.py

- uv-grid.png: a 256 x 256 texture-coordinate test card: 8 x 8 cells blending red along u and
  green along v (so (0, 0), bottom left, is dark and (1, 1), top right, is yellow), white grid
  lines, and a blue square in the top-left cell (u < 1/8, v > 7/8) that shows the orientation.
- die.png: a 384 x 256 atlas of a die's six faces (3 x 2 cells of 128 pixels: 1 2 3 on the top
  row, 4 5 6 below), black pips on ivory with a dark rim.
- die.obj, die.mtl: a unit cube whose faces take their cells of die.png through `vt` (opposite
  faces add up to 7), and a material with `map_Kd die.png`.
"""
from PIL import Image, ImageDraw

# uv-grid.png
N, CELLS = 256, 8
grid = Image.new("RGB", (N, N))
px = grid.load()
for y in range(N):
    for x in range(N):
        u, v = (x + 0.5) / N, 1.0 - (y + 0.5) / N
        cu, cv = int(u * CELLS), int(v * CELLS)
        shade = 0.55 + 0.45 * ((cu + cv) % 2)
        px[x, y] = (int(255 * shade * (0.15 + 0.85 * cu / (CELLS - 1))), int(255 * shade * (0.15 + 0.85 * cv / (CELLS - 1))), 40)
d = ImageDraw.Draw(grid)
step = N // CELLS
for k in range(0, N + 1, step):
    d.line([(k, 0), (k, N)], fill=(255, 255, 255), width=2)
    d.line([(0, k), (N, k)], fill=(255, 255, 255), width=2)
d.rectangle([6, 6, step - 6, step - 6], fill=(30, 60, 230))
grid.save("uv-grid.png", optimize=True)

# die.png
S = 128
die = Image.new("RGB", (3 * S, 2 * S), (40, 30, 25))
d = ImageDraw.Draw(die)
PIPS = {
    1: [(0.5, 0.5)],
    2: [(0.25, 0.25), (0.75, 0.75)],
    3: [(0.25, 0.25), (0.5, 0.5), (0.75, 0.75)],
    4: [(0.25, 0.25), (0.75, 0.25), (0.25, 0.75), (0.75, 0.75)],
    5: [(0.25, 0.25), (0.75, 0.25), (0.5, 0.5), (0.25, 0.75), (0.75, 0.75)],
    6: [(0.25, 0.22), (0.75, 0.22), (0.25, 0.5), (0.75, 0.5), (0.25, 0.78), (0.75, 0.78)],
}
for face in range(1, 7):
    cx, cy = (face - 1) % 3, (face - 1) // 3
    x0, y0 = cx * S, cy * S
    d.rounded_rectangle([x0 + 4, y0 + 4, x0 + S - 5, y0 + S - 5], radius=18, fill=(238, 228, 205))
    r = 11
    colour = (170, 20, 25) if face == 1 else (20, 20, 24)
    for px_, py_ in PIPS[face]:
        x, y = x0 + px_ * S, y0 + py_ * S
        d.ellipse([x - r, y - r, x + r, y + r], fill=colour)
die.save("die.png", optimize=True)


# die.obj: corners of the unit cube, one quad per face with its atlas cell (v up).
def cell(face):
    cx, cy = (face - 1) % 3, (face - 1) // 3
    u0, u1 = cx / 3, (cx + 1) / 3
    v1, v0 = 1 - cy / 2, 1 - (cy + 1) / 2
    return [(u0, v0), (u1, v0), (u1, v1), (u0, v1)]


# Each face: its corners counter-clockwise from outside, starting bottom left as seen upright.
FACES = {
    1: [(-1, -1, 1), (1, -1, 1), (1, 1, 1), (-1, 1, 1)],  # +z, front
    6: [(1, -1, -1), (-1, -1, -1), (-1, 1, -1), (1, 1, -1)],  # -z, back
    2: [(-1, 1, 1), (1, 1, 1), (1, 1, -1), (-1, 1, -1)],  # +y, top
    5: [(-1, -1, -1), (1, -1, -1), (1, -1, 1), (-1, -1, 1)],  # -y, bottom
    3: [(1, -1, 1), (1, -1, -1), (1, 1, -1), (1, 1, 1)],  # +x, right
    4: [(-1, -1, -1), (-1, -1, 1), (-1, 1, 1), (-1, 1, -1)],  # -x, left
}
lines = ["# A die: a cube of side 2 with its faces' cells of die.png (make_textures.py, CC0)", "mtllib die.mtl"]
for corners in FACES.values():
    lines += [f"v {x} {y} {z}" for x, y, z in corners]
for face in FACES:
    lines += [f"vt {u:.6f} {v:.6f}" for u, v in cell(face)]
lines.append("usemtl die")
for i in range(6):
    k = 4 * i
    lines.append("f " + " ".join(f"{k + j + 1}/{k + j + 1}" for j in range(4)))
open("die.obj", "w").write("\n".join(lines) + "\n")
open("die.mtl", "w").write("# The die's material (make_textures.py, CC0)\nnewmtl die\nKd 1 1 1\nKs 0.3 0.3 0.3\nNs 60\nmap_Kd die.png\n")
