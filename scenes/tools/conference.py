#!/usr/bin/env python3
"""Convert the Conference Room mesh into scenes/conference.obj.gz + scenes/conference.mtl.

Usage:
    python3 scenes/tools/conference.py PATH/conference.zip [OUTDIR]

Input: conference.zip (from taqu/BoundingVolumeHierarchy) holding conference/conference.bin, which
is C source with `float conference_vertices[]` (x, y, z triples, Y up) and
`unsigned int conference_indices[]` (0-based triangles), and conference/copyright.txt.
OUTDIR defaults to the `scenes` directory next to this script.

What the script does (details and reasons in scenes/README.md):
  * scale: model units -> metres with SCALE (measured so the room matches Greg Ward's stated
    35.5 x 22 x 8.9 ft), and a shift in y that puts the floor at y = 0;
  * every source triangle is kept, in source order within each material (zero-area ones too:
    the renderer drops them itself);
  * materials, which the mesh does not have, are assigned by the geometric rule in classify();
  * our addition: twelve downward-facing emissive quads just under the ceiling, as the mesh
    contains no light fixtures.
Output is byte-for-byte deterministic (gzip level 9, mtime 0).
"""
import gzip
import io
import os
import re
import sys
import zipfile

SCALE = 0.0041615        # metres per model unit (copyright.txt says 0.003; see the notes)
FLOOR_Y = -1.57216       # model y of the floor plane -> 0 m
CEILING_Y = 650.293      # model y of the ceiling plane
ROOM_X = (-946.888, 1653.25)   # inner faces of the end walls (model units)
ROOM_Z = (-1014.57, 595.246)   # inner faces of the side walls (window wall at -z)

# Materials: name, Kd, Ke (None: not emissive). Plausible diffuse colours, not measured.
MATERIALS = [
    ("conf_carpet",  (0.20, 0.22, 0.27), None),   # floor: blue-grey carpet
    ("conf_ceiling", (0.80, 0.80, 0.78), None),   # ceiling
    ("conf_wall",    (0.62, 0.58, 0.52), None),   # walls, window recesses
    ("conf_wood",    (0.35, 0.20, 0.10), None),   # conference table (dark wood)
    ("conf_chair",   (0.20, 0.20, 0.22), None),   # chairs and other low furniture
    ("conf_other",   (0.50, 0.50, 0.50), None),   # everything else
    ("conf_light",   (0.0, 0.0, 0.0), (16.0, 16.0, 16.0)),  # our ceiling panels
]

# Table: the two flat table-top slabs (y 168-179) and the four pedestals under them all lie in
# this footprint (model units); no chair part lies entirely inside it.
TABLE_BOX = ((70.0, 960.0), (-3.0, 185.0), (-290.0, 12.0))
# A cluster of 462 tiny components (each under 3 units = 12 mm across, 206,560 triangles in all)
# sits on the floor in the corner x ~ 1614-1653, z ~ -1020..-990 (model units). They are
# classed as "other" explicitly.
BLOB_BOX = ((1614.0, 1653.25), (-3.0, 3.0), (-1020.0, -990.0))
CHAIR_MAX_Y = 200.0      # components whose top is below this (0.84 m) are chairs / low furniture

# Light panels (our addition): 4 x 3 grid, 1.2 m (x) by 0.6 m (z), centred in equal cells of the
# room's floor plan, 1 cm under the ceiling, facing down.
LIGHT_GRID = (4, 3)
LIGHT_SIZE = (1.2, 0.6)
LIGHT_DROP = 0.01

TRIANGLES = 331179
VERTICES = 194399


def read_zip(path):
    with zipfile.ZipFile(path) as z:
        text = z.read("conference/conference.bin").decode("ascii")
    arrays = {}
    for name, body in re.findall(r"(\w+)\[\]\s*=\s*\{([^}]*)\}", text):
        arrays[name] = body.replace(",", " ").split()
    flat = [float(x) for x in arrays["conference_vertices"]]
    idx = [int(x) for x in arrays["conference_indices"]]
    verts = [tuple(flat[i:i + 3]) for i in range(0, len(flat), 3)]
    tris = [tuple(idx[i:i + 3]) for i in range(0, len(idx), 3)]
    return verts, tris


def components(verts, tris):
    """Connected components over shared indices and shared (identical) positions."""
    parent = list(range(len(verts)))

    def find(x):
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    def union(a, b):
        ra, rb = find(a), find(b)
        if ra != rb:
            parent[max(ra, rb)] = min(ra, rb)

    first = {}
    for i, p in enumerate(verts):
        j = first.setdefault(p, i)
        if j != i:
            union(i, j)
    for a, b, c in tris:
        union(a, b)
        union(a, c)
    comp = [find(a) for a, _, _ in tris]
    box = {}
    for t, r in enumerate(comp):
        lo, hi = box.get(r, ([1e30] * 3, [-1e30] * 3))
        for i in tris[t]:
            for k in range(3):
                v = verts[i][k]
                if v < lo[k]:
                    lo[k] = v
                if v > hi[k]:
                    hi[k] = v
        box[r] = (lo, hi)
    return comp, box


def inside(lo, hi, b):
    return all(b[k][0] <= lo[k] and hi[k] <= b[k][1] for k in range(3))


def classify(verts, tris):
    """The material rule, per triangle (T) and per connected component (C):
       C spans the whole room (the shell):  T facing up at floor level -> carpet,
                                            T facing down at ceiling level -> ceiling,
                                            any other T -> wall;
       C inside BLOB_BOX                     -> other;
       C inside TABLE_BOX                    -> wood;
       C top below CHAIR_MAX_Y               -> chair;
       C lying in a wall plane or beyond it (window recesses) -> wall;
       anything else                         -> other."""
    comp, box = components(verts, tris)
    out = []
    for t, (a, b, c) in enumerate(tris):
        lo, hi = box[comp[t]]
        A, B, C = verts[a], verts[b], verts[c]
        if hi[0] - lo[0] > 2500.0:
            u = [B[k] - A[k] for k in range(3)]
            w = [C[k] - A[k] for k in range(3)]
            ny = u[2] * w[0] - u[0] * w[2]
            n2 = (u[1] * w[2] - u[2] * w[1]) ** 2 + ny ** 2 + (u[0] * w[1] - u[1] * w[0]) ** 2
            ymax = max(A[1], B[1], C[1])
            ymin = min(A[1], B[1], C[1])
            if n2 > 0 and ny > 0.9 * n2 ** 0.5 and ymax < FLOOR_Y + 1.0:
                out.append("conf_carpet")
            elif n2 > 0 and ny < -0.9 * n2 ** 0.5 and ymin > CEILING_Y - 1.0:
                out.append("conf_ceiling")
            else:
                out.append("conf_wall")
        elif inside(lo, hi, BLOB_BOX):
            out.append("conf_other")
        elif inside(lo, hi, TABLE_BOX):
            out.append("conf_wood")
        elif hi[1] < CHAIR_MAX_Y:
            out.append("conf_chair")
        elif (hi[2] < ROOM_Z[0] + 1.0 or lo[2] > ROOM_Z[1] - 1.0
              or hi[0] < ROOM_X[0] + 1.0 or lo[0] > ROOM_X[1] - 1.0):
            out.append("conf_wall")
        else:
            out.append("conf_other")
    return out


def fmt(x):
    """Fixed 5 decimals (10 micrometres: the small parts are only a few mm), zeros trimmed."""
    s = ("%.5f" % x).rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def to_m(p):
    return (p[0] * SCALE, (p[1] - FLOOR_Y) * SCALE, p[2] * SCALE)


def light_quads():
    x0, x1 = ROOM_X[0] * SCALE, ROOM_X[1] * SCALE
    z0, z1 = ROOM_Z[0] * SCALE, ROOM_Z[1] * SCALE
    y = (CEILING_Y - FLOOR_Y) * SCALE - LIGHT_DROP
    nx, nz = LIGHT_GRID
    hx, hz = LIGHT_SIZE[0] / 2, LIGHT_SIZE[1] / 2
    quads = []
    for j in range(nz):
        cz = z0 + (z1 - z0) * (j + 0.5) / nz
        for i in range(nx):
            cx = x0 + (x1 - x0) * (i + 0.5) / nx
            # a, b, c, d with (b-a)x(c-a) pointing to -y
            quads.append(((cx - hx, y, cz - hz), (cx + hx, y, cz - hz),
                          (cx + hx, y, cz + hz), (cx - hx, y, cz + hz)))
    return quads


def main():
    if len(sys.argv) < 2:
        raise SystemExit(__doc__)
    here = os.path.dirname(os.path.abspath(__file__))
    out_dir = sys.argv[2] if len(sys.argv) > 2 else os.path.dirname(here)
    verts, tris = read_zip(sys.argv[1])
    if len(verts) != VERTICES or len(tris) != TRIANGLES:
        raise SystemExit("expected %d vertices / %d triangles, found %d / %d"
                         % (VERTICES, TRIANGLES, len(verts), len(tris)))
    mats = classify(verts, tris)
    vm = [to_m(p) for p in verts]
    vs = [tuple(fmt(c) for c in p) for p in vm]

    # zero-area triangles in the source and after rounding (reported, kept)
    def zero(P):
        A, B, C = P
        u = [B[k] - A[k] for k in range(3)]
        w = [C[k] - A[k] for k in range(3)]
        return (u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2],
                u[0] * w[1] - u[1] * w[0]) == (0.0, 0.0, 0.0)
    z_src = sum(zero([verts[i] for i in t]) for t in tris)
    z_out = sum(zero([tuple(float(c) for c in vs[i]) for i in t]) for t in tris)

    out = io.StringIO()
    w = out.write
    w("# Conference Room: Anat Grynberg and Greg Ward's Radiance model, recreated as a mesh by\n")
    w("# Kenzie Lamar. Converted by scenes/tools/conference.py: metres (%.7g m per model unit),\n" % SCALE)
    w("# floor at y = 0, Y up; materials assigned by a geometric rule; conf_light panels are our\n")
    w("# addition. %d vertices, %d model triangles + %d light triangles\n"
      % (len(verts), len(tris), 2 * LIGHT_GRID[0] * LIGHT_GRID[1]))
    w("mtllib conference.mtl\n")
    for p in vs:
        w("v %s %s %s\n" % p)
    counts = {}
    for name, _, _ in MATERIALS:
        if name == "conf_light":
            continue
        sel = [t for t, m in enumerate(mats) if m == name]
        counts[name] = len(sel)
        if not sel:
            continue
        w("# %s: %d triangles\n" % (name, len(sel)))
        w("usemtl %s\n" % name)
        for t in sel:
            a, b, c = tris[t]
            w("f %d %d %d\n" % (a + 1, b + 1, c + 1))
    base = len(verts)
    w("# conf_light: our addition, %d downward-facing panels 1 cm under the ceiling\n"
      % (LIGHT_GRID[0] * LIGHT_GRID[1]))
    quads = light_quads()
    for q in quads:
        for p in q:
            w("v %s %s %s\n" % tuple(fmt(c) for c in p))
    w("usemtl conf_light\n")
    for n in range(len(quads)):
        k = base + 4 * n
        w("f %d %d %d\n" % (k + 1, k + 2, k + 3))
        w("f %d %d %d\n" % (k + 1, k + 3, k + 4))

    obj_path = os.path.join(out_dir, "conference.obj.gz")
    with open(obj_path, "wb") as fh:
        with gzip.GzipFile(filename="", mode="wb", fileobj=fh, compresslevel=9, mtime=0) as gz:
            gz.write(out.getvalue().encode("ascii"))

    m = io.StringIO()
    m.write("# Conference Room materials: the source mesh has none; plausible diffuse colours\n")
    m.write("# assigned by scenes/tools/conference.py (no textures). conf_light is our addition.\n")
    for name, kd, ke in MATERIALS:
        m.write("\nnewmtl %s\nKd %.2f %.2f %.2f\n" % ((name,) + kd))
        if ke:
            m.write("Ke %g %g %g\n" % ke)
    with open(os.path.join(out_dir, "conference.mtl"), "w", newline="\n") as fh:
        fh.write(m.getvalue())

    print("triangles %d (+%d light), vertices %d" % (len(tris), 2 * len(quads), len(verts)))
    print("zero-area triangles: %d in the source, %d after rounding" % (z_src, z_out))
    print("per material:", ", ".join("%s %d" % kv for kv in counts.items()))
    ys = [p[1] for p in vm]
    print("bbox (m): x %.4f..%.4f y %.4f..%.4f z %.4f..%.4f" % (
        min(p[0] for p in vm), max(p[0] for p in vm), min(ys), max(ys),
        min(p[2] for p in vm), max(p[2] for p in vm)))
    print("wrote", obj_path)


if __name__ == "__main__":
    main()
