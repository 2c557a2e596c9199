#!/usr/bin/env python3
"""Convert Marko Dabrovic's Sponza atrium into scenes/sponza.obj.gz + scenes/sponza.mtl.

Usage:
    python3 scenes/tools/sponza.py PATH/sponza.zip PATH/sponza.mtl [OUTDIR]

Inputs (see scenes/README.md for where they come from):
  * sponza.zip  - holds sponza.obj, a Max2Obj 4.0 (2001) export with 34 `g` groups and no
                  materials (66,454 triangles, Y up, metres);
  * sponza.mtl  - the 20 `sp_*` materials of the later material-assigned release; only their
                  `Kd` is used (textures are not converted).
OUTDIR defaults to the `scenes` directory next to this script.

The output keeps the vertex list and every triangle (same order), replaces each group by a
`usemtl` of the material chosen by hand in GROUP_MATERIAL below, and adds one emissive quad
(`sky_light`, our addition) above the atrium's open roof. Texture coordinates, normals,
smoothing groups and group names are dropped (the group name survives as a comment).
Output is byte-for-byte deterministic (gzip level 9, mtime 0).
"""
import gzip
import io
import os
import sys
import zipfile

# Each of the 34 groups of the 2001 export -> one sp_* material. Decided by hand from the group
# name and, for the anonymous `objectNN` groups, from their bounding box, height band and
# position (heights in metres above the atrium floor at y = 0.09; the atrium is x +-10.9,
# z +-2.5, ground-floor arcade capitals at y 2.33-2.69, first-floor column bases at 5.88-6.04,
# first-floor capitals at 7.74-8.12). Material prefixes 00 / 01 are read as ground / first floor.
GROUP_MATERIAL = [
    # group                  material              why
    ("arcs_floor_small",     "sp_00_luk_mali"),    # ground-floor arches, short (x) sides
    ("arcs_03",              "sp_00_luk_mali"),    # ground-floor arches, y 2.69-4.97
    ("object32",             "sp_svod_kapitel"),   # wall capitals on the outer gallery walls
                                                   # (x +-16.2, z +-7.2) at y 2.3-3 and 7.7-8.1,
                                                   # where the gallery vaults spring
    ("object31",             "sp_01_stub_baza_"),  # bases of the first-floor corner piers
                                                   # (y 5.88-6.04, x +-11.6)
    ("pillar_corners",       "sp_01_stub_kut"),    # first-floor corner piers (kut = corner)
    ("pillar_floor",         "sp_00_stup"),        # ground-floor columns (y 0.09-2.33)
    ("object28",             "sp_01_stub_baza"),   # bases of the first-floor square piers
                                                   # (y 5.88-6.04, x +-7.0)
    ("object27",             "sp_00_luk_mal1"),    # capitals of the first-floor square piers
                                                   # (y 7.74-8.12, x +-7.0); sp_00_luk_mal1
                                                   # carries the 01_st_kp (capital) texture
    ("pillar_quader",        "sp_01_stub"),        # first-floor square piers (quader)
    ("pillar_round",         "sp_01_stup"),        # first-floor round columns
    ("arcs_floor_long",      "sp_00_luk_mali"),    # ground-floor arches, long (z) sides
    ("object23",             "sp_vijenac"),        # cornice bands round the atrium at
                                                   # y ~5.8, ~11 and 15.5-15.65 (vijenac)
    ("floors",               "sp_00_pod"),         # floors (atrium, galleries, outside)
    ("object21",             "sp_00_zid"),         # flat atrium-facing wall strips between and
                                                   # above the arches (normals only +-x/+-z)
    ("puillar_floor_corner", "sp_01_stub_kut"),    # ground-floor corner piers (kut = corner)
    ("object19",             "sp_00_luk_mal1"),    # capitals of the first-floor corner piers
    ("relief",               "sp_02_reljef"),      # relief panel on the x = +10.93 end wall
    ("arcs_small",           "sp_01_luk_a"),       # first-floor arches, short sides
    ("holes",                "sp_00_zid"),         # top-storey wall with rectangular openings
    ("outside01",            "sp_zid_vani"),       # outside faces of the building (vani)
    ("arcs_long",            "sp_01_luk_a"),       # first-floor arches, long sides
    ("parapet",              "sp_vijenac"),        # horizontal ledge tops (all normals +y) at
                                                   # the cornice heights
    ("round_holes",          "sp_00_zid"),         # top-storey wall with round openings
    ("ceiling",              "sp_00_svod"),        # gallery vaults (svod), y 2.69-10.09
    ("arcs_01",              "sp_01_luk_a"),       # first-floor arches, y 8.12-9.72
    ("object6",              "sp_svod_kapitel"),   # ground-floor capitals of the corner piers
                                                   # (y 2.33-2.69, x +-11.7); vaults spring here
    ("object5",              "sp_svod_kapitel"),   # ground-floor column capitals (x +-7.05)
    ("object4",              "sp_00_luk_mal1"),    # first-floor round-column capitals
                                                   # (y 7.74-8.12, 4,032 triangles)
    ("object3",              "sp_01_stup_baza"),   # first-floor round-column bases
                                                   # (y 5.88-6.04, 4,977 triangles)
    ("arcs_02",              "sp_01_luk_a"),       # first-floor arches, y 8.12-9.72
    ("arcs_04",              "sp_00_luk_mali"),    # ground-floor arches, y 2.69-4.97
    ("walls",                "sp_00_zid"),         # walls (zid)
    ("windows",              "sp_00_prozor"),      # windows in the long outer walls (prozor)
    ("doors",                "sp_00_vrata_kock"),  # the two doors (vrata) in the long walls
]

# sp_00_prozor has Kd 1 1 1 in the source; the renderer needs albedo < 1.
KD_CLAMP = 0.9

# Our addition: the original has no lights (it is lit by the sky through the open roof). One
# quad the size of the roof opening (the top cornice's inner edge is at |x| = 10.81, |z| = 2.42,
# y 15.49-15.65), facing down, 1 m above the cornice's top. It first sat at y = 15.45, just under
# the cornice: the walls a few centimetres from its edges then saw it at grazing distance, and
# their one-light-sample estimates were fireflies (paper-notes.md, "Accuracy on the real scenes").
SKY_Y = 16.65
SKY_X = 10.8
SKY_Z = 2.4
SKY_KE = (9.0, 9.0, 9.0)

TRIANGLES = 66454


def fmt(x):
    """Fixed 4 decimals (0.1 mm), trailing zeros dropped."""
    s = "%.4f" % x
    s = s.rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def read_obj(zip_path):
    with zipfile.ZipFile(zip_path) as z:
        text = z.read("sponza.obj").decode("latin-1")
    verts, groups, cur = [], [], None
    for line in text.splitlines():
        p = line.split()
        if not p:
            continue
        if p[0] == "v":
            verts.append(tuple(float(x) for x in p[1:4]))
        elif p[0] == "g":  # "g NAME" opens a group, a bare "g" closes it
            cur = (p[1], []) if len(p) > 1 else None
            if cur:
                groups.append(cur)
        elif p[0] == "f":
            idx = [int(t.split("/")[0]) for t in p[1:]]
            if cur is None or any(i <= 0 for i in idx):
                raise SystemExit("face outside a group or with a relative index")
            for k in range(1, len(idx) - 1):  # fan (the file has triangles only)
                cur[1].append((idx[0], idx[k], idx[k + 1]))
    return verts, groups


def read_mtl(mtl_path):
    kd, name = {}, None
    for line in open(mtl_path, encoding="latin-1"):
        p = line.split()
        if not p:
            continue
        if p[0] == "newmtl":
            name = p[1]
        elif p[0] == "Kd" and name:
            kd[name] = tuple(float(x) for x in p[1:4])
    return kd


def main():
    if len(sys.argv) < 3:
        raise SystemExit(__doc__)
    zip_path, mtl_path = sys.argv[1], sys.argv[2]
    here = os.path.dirname(os.path.abspath(__file__))
    out_dir = sys.argv[3] if len(sys.argv) > 3 else os.path.dirname(here)

    verts, groups = read_obj(zip_path)
    kd = read_mtl(mtl_path)
    mapping = dict(GROUP_MATERIAL)
    names = [g for g, _ in groups]
    if sorted(names) != sorted(mapping) or len(names) != 34:
        raise SystemExit("group list differs from the mapping table: %s" % names)
    ntri = sum(len(f) for _, f in groups)
    if ntri != TRIANGLES:
        raise SystemExit("expected %d triangles, found %d" % (TRIANGLES, ntri))

    # quantisation must not make any triangle degenerate
    q = [tuple(round(c, 4) for c in v) for v in verts]
    flat = 0
    for _, faces in groups:
        for a, b, c in faces:
            A, B, C = q[a - 1], q[b - 1], q[c - 1]
            u = [B[k] - A[k] for k in range(3)]
            w = [C[k] - A[k] for k in range(3)]
            n = (u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0])
            if n == (0, 0, 0) or max(abs(x) for x in n) < 1e-12:
                flat += 1

    out = io.StringIO()
    w = out.write
    w("# Sponza atrium by Marko Dabrovic (UVs and cracks fixed by Kenzie Lamar, Vicarious Visions;\n")
    w("# bump maps by Morgan McGuire). Converted by scenes/tools/sponza.py: metres, Y up,\n")
    w("# materials assigned per group by hand, no textures; the sky_light quad is our addition.\n")
    w("# %d vertices, %d model triangles + 2 light triangles\n" % (len(verts), ntri))
    w("mtllib sponza.mtl\n")
    for v in verts:
        w("v %s %s %s\n" % (fmt(v[0]), fmt(v[1]), fmt(v[2])))
    used = []
    for name, faces in groups:
        mat = mapping[name]
        if mat not in used:
            used.append(mat)
        w("# group %s -> %s\n" % (name, mat))
        w("usemtl %s\n" % mat)
        for a, b, c in faces:
            w("f %d %d %d\n" % (a, b, c))
    # sky light: corners ordered so that (b-a)x(c-a) points to -y
    base = len(verts)
    w("# sky_light: our addition, a downward-facing quad above the open roof\n")
    for x, z in ((-SKY_X, -SKY_Z), (SKY_X, -SKY_Z), (SKY_X, SKY_Z), (-SKY_X, SKY_Z)):
        w("v %s %s %s\n" % (fmt(x), fmt(SKY_Y), fmt(z)))
    w("usemtl sky_light\n")
    w("f %d %d %d\n" % (base + 1, base + 2, base + 3))
    w("f %d %d %d\n" % (base + 1, base + 3, base + 4))

    data = out.getvalue().encode("ascii")
    obj_path = os.path.join(out_dir, "sponza.obj.gz")
    with open(obj_path, "wb") as fh:
        with gzip.GzipFile(filename="", mode="wb", fileobj=fh, compresslevel=9, mtime=0) as gz:
            gz.write(data)

    m = io.StringIO()
    m.write("# Sponza materials: Kd of the sp_* materials of the material-assigned Sponza release\n")
    m.write("# (kevinriehm/dabrovic-sponza sponza.mtl). Textures and bump maps are NOT used.\n")
    m.write("# sky_light is our addition (the original is lit by the open sky).\n")
    for mat in used:
        r, g, b = kd[mat]
        note = ""
        if max(r, g, b) >= 1.0:
            r, g, b = (min(c, KD_CLAMP) for c in (r, g, b))
            note = "# source Kd 1 1 1, clamped to %.2f (albedo must be < 1)\n" % KD_CLAMP
        m.write("\nnewmtl %s\n%sKd %.6f %.6f %.6f\n" % (mat, note, r, g, b))
    m.write("\nnewmtl sky_light\nKd 0 0 0\nKe %g %g %g\n" % SKY_KE)
    with open(os.path.join(out_dir, "sponza.mtl"), "w", newline="\n") as fh:
        fh.write(m.getvalue())

    unused = sorted(set(kd) - set(used))
    print("triangles %d (+2 light), vertices %d, zero-area triangles after rounding %d (the source has 1)" % (ntri, len(verts), flat))
    print("materials used %d, unused: %s" % (len(used), " ".join(unused)))
    print("wrote", obj_path)


if __name__ == "__main__":
    main()
