#!/usr/bin/env python3
"""Convert Greg Ward's Radiance "office" model into a triangle mesh (OBJ + MTL) for wfic.

Pure Python (standard library only).  It needs the Radiance programs `xform` (to expand the
scene's inline commands: !genbox, !genrev, !genprism, !genblinds, !xform ...) and `pvalue`
(to average the pine picture) on PATH, e.g. from `pip install pyradiance`.

Usage (either an exported office + lib directory, or the git dir of a Radiance mirror whose
branch `auxiliary` holds obj/office and lib/):

    python3 scenes/tools/rad2obj.py --office DIR/obj/office --lib DIR/lib --out scenes
    python3 scenes/tools/rad2obj.py --git-dir /work/.mirror/LBNL-ETA+Radiance/repo --out scenes

Optional: --rad FILE also writes the triangles back as a Radiance scene (plastic/light
polygons) for an oconv/rpict comparison with the original; --expanded FILE keeps the
`xform -e` output.

Conversion rules (see scenes/README.md):
  * scene files in office.rif order: model.b90 desk misc window blinds lights lamp picture
  * polygon: ear clipping in the polygon's plane, keeping Radiance's winding (front side =
    counter-clockwise seen from the front), so concave outlines and the seam-bridged window
    hole of wall.front come out right.
  * sphere/cylinder/cone face outwards, bubble/tube/cup face inwards, ring faces along its
    direction vector.  SEG = 24 segments around, SPHERE_RINGS = 12 from pole to pole.
    Cylinders, tubes, cones and cups get no end caps (Radiance has none).
  * materials: the modifier chain is followed to the first material; plastic/plastic2/
    metal/metal2/trans -> Kd = its RGB (specular part ignored), clamped to <= 0.98;
    light/glow/illum/spotlight -> emitter, Ke = RGB radiance, Kd = 0.
    glass/dielectric/interface: dropped (the window becomes an opening to the dark outside).
    mirror: grey diffuse, Kd = min(its RGB, 0.98).
  * patterns and textures (brightfunc, colorfunc, brighttext, colortext, texfunc, colorpict,
    colordata, brightdata ...) are dropped: the underlying material's colour is used; a
    mixfunc/mixdata/mixpict/mixtext is replaced by its first (foreground) modifier.
    (`alias` is not parsed; the office has none.)
    Exception: a colorpict whose picture can be read is replaced by the picture's mean colour
    times the material colour (the office's pine painting).
  * scene units -> metres (x 0.0762: one unit is 3 inches), Y stays up. The furniture files
    (*.norm) are modelled in inches and placed with `xform -s .3333`, so a scene unit is
    3 inches: the room is 60 x 35.5 x 60 units = 4.57 x 2.71 x 4.57 m, the desk top 0.69 m high.
    (Read as inches, the room would be 0.90 m high.)
"""

import argparse
import gzip
import io
import math
import os
import shutil
import subprocess
import sys
import tarfile
import tempfile
from collections import OrderedDict, Counter

SCENE_FILES = ["model.b90", "desk", "misc", "window", "blinds", "lights", "lamp", "picture"]
LIB_FILES = ["woodpat.cal", "weave.cal", "picture.cal", "helvet.fnt", "page1.txt",
             "page2.txt", "pine.hdr"]
SCALE = 0.0762          # scene units (3 inches, see the docstring) -> metres
SEG = 24                # segments around every round primitive
SPHERE_RINGS = 12       # latitude bands of a sphere
KD_MAX = 0.98

DIFFUSE_MATS = {"plastic", "plastic2", "metal", "metal2", "trans", "trans2"}
EMITTER_MATS = {"light", "glow", "illum", "spotlight"}
DROPPED_MATS = {"glass", "dielectric", "interface"}
GREY_MATS = {"mirror"}
MATERIAL_TYPES = DIFFUSE_MATS | EMITTER_MATS | DROPPED_MATS | GREY_MATS | {
    "plasfunc", "metfunc", "transfunc", "plasdata", "metdata", "transdata", "BRTDfunc",
    "antimatter", "prism1", "prism2", "mist", "ashik2", "WGMDfunc", "BSDF", "aBSDF"}
SURFACES = {"polygon", "sphere", "bubble", "cylinder", "tube", "cone", "cup", "ring"}


# ----------------------------------------------------------------------------------------
# small vector helpers
def sub(a, b): return (a[0] - b[0], a[1] - b[1], a[2] - b[2])
def add(a, b): return (a[0] + b[0], a[1] + b[1], a[2] + b[2])
def mul(a, s): return (a[0] * s, a[1] * s, a[2] * s)
def dot(a, b): return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
def cross(a, b): return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])
def norm(a): return math.sqrt(dot(a, a))
def unit(a):
    n = norm(a)
    return (a[0] / n, a[1] / n, a[2] / n)


def frame(w):
    """Orthonormal u, v with u x v = w (w must be a unit vector)."""
    helper = (1.0, 0.0, 0.0) if abs(w[0]) < 0.6 else (0.0, 1.0, 0.0)
    u = unit(cross(helper, w))
    v = cross(w, u)
    return u, v


# ----------------------------------------------------------------------------------------
# Radiance scene parsing
def tokenize(text):
    toks = []
    for line in text.splitlines():
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        if s.startswith("!"):
            raise SystemExit("unexpanded command left in the scene: " + s)
        toks.extend(s.split())
    return toks


def parse(text):
    toks = tokenize(text)
    prims, i = [], 0
    while i < len(toks):
        mod, typ, name = toks[i:i + 3]
        i += 3
        n = int(toks[i]); sargs = toks[i + 1:i + 1 + n]; i += 1 + n
        n = int(toks[i]); i += 1 + n
        n = int(toks[i]); rargs = [float(x) for x in toks[i + 1:i + 1 + n]]; i += 1 + n
        prims.append((mod, typ, name, sargs, rargs))
    return prims


# ----------------------------------------------------------------------------------------
# tessellation (all in inches; each returns a list of triangles (a, b, c), front = (b-a)x(c-a))
def tri_area(a, b, c):
    return 0.5 * norm(cross(sub(b, a), sub(c, a)))


def newell(pts):
    n = [0.0, 0.0, 0.0]
    for i, p in enumerate(pts):
        q = pts[(i + 1) % len(pts)]
        n[0] += (p[1] - q[1]) * (p[2] + q[2])
        n[1] += (p[2] - q[2]) * (p[0] + q[0])
        n[2] += (p[0] - q[0]) * (p[1] + q[1])
    return tuple(n)


def ear_clip(pts):
    """Triangulate a planar simple (possibly concave, possibly seam-bridged) polygon.
    Returns index triples in the polygon's own winding."""
    nrm = newell(pts)
    if norm(nrm) == 0:
        return []
    w = unit(nrm)
    u, v = frame(w)
    p2 = [(dot(p, u), dot(p, v)) for p in pts]      # CCW in (u, v) because u x v = w
    idx = list(range(len(pts)))
    scale = max(max(abs(c) for c in q) for q in p2) or 1.0
    eps = 1e-9 * scale * scale

    def crs(a, b, c):
        return (p2[b][0] - p2[a][0]) * (p2[c][1] - p2[a][1]) - (p2[b][1] - p2[a][1]) * (p2[c][0] - p2[a][0])

    def same(a, b):
        return abs(p2[a][0] - p2[b][0]) + abs(p2[a][1] - p2[b][1]) <= 1e-9 * scale

    def blocks(a, b, c, others, strict):
        for k in others:
            if same(k, a) or same(k, b) or same(k, c):
                continue
            d1, d2, d3 = crs(a, b, k), crs(b, c, k), crs(c, a, k)
            if strict:
                if d1 > eps and d2 > eps and d3 > eps:
                    return True
            elif d1 >= -eps and d2 >= -eps and d3 >= -eps:
                return True
        return False

    tris = []
    while len(idx) > 3:
        m = len(idx)
        found = None
        for strict in (False, True):
            for j in range(m):
                a, b, c = idx[j - 1], idx[j], idx[(j + 1) % m]
                if crs(a, b, c) <= eps:
                    continue
                others = [k for k in idx if k not in (a, b, c)]
                if not blocks(a, b, c, others, strict):
                    found = j
                    break
            if found is not None:
                break
        if found is None:
            # only degenerate (collinear / coincident) corners left: drop the flattest one
            j = min(range(m), key=lambda j: abs(crs(idx[j - 1], idx[j], idx[(j + 1) % m])))
            del idx[j]
            continue
        a, b, c = idx[found - 1], idx[found], idx[(found + 1) % m]
        tris.append((a, b, c))
        del idx[found]
    if len(idx) == 3 and crs(*idx) > eps:
        tris.append(tuple(idx))
    return tris


def polygon(r):
    pts = [tuple(r[i:i + 3]) for i in range(0, len(r), 3)]
    return [(pts[a], pts[b], pts[c]) for a, b, c in ear_clip(pts)], pts


def circle(c, u, v, rad, i):
    t = 2.0 * math.pi * i / SEG
    return add(c, add(mul(u, rad * math.cos(t)), mul(v, rad * math.sin(t))))


def cone_like(p0, p1, r0, r1, inward):
    w = unit(sub(p1, p0))
    u, v = frame(w)
    tris = []
    for i in range(SEG):
        a, b = circle(p0, u, v, r0, i), circle(p0, u, v, r0, i + 1)
        c, d = circle(p1, u, v, r1, i + 1), circle(p1, u, v, r1, i)
        for t in ((a, b, c), (a, c, d)):
            if tri_area(*t) > 0:
                tris.append((t[0], t[2], t[1]) if inward else t)
    return tris


def ring(c, d, r0, r1):
    w = unit(d)
    u, v = frame(w)
    r0, r1 = min(r0, r1), max(r0, r1)
    tris = []
    for i in range(SEG):
        if r0 == 0:
            tris.append((c, circle(c, u, v, r1, i), circle(c, u, v, r1, i + 1)))
        else:
            a, b = circle(c, u, v, r0, i), circle(c, u, v, r1, i)
            e, f = circle(c, u, v, r1, i + 1), circle(c, u, v, r0, i + 1)
            tris += [(a, b, e), (a, e, f)]
    return tris


def sphere(c, rad, inward):
    if rad < 0:                     # a negative radius turns a sphere inside out
        rad, inward = -rad, not inward
    w = (0.0, 1.0, 0.0)
    u, v = frame(w)

    def pt(j, i):
        ph = math.pi * j / SPHERE_RINGS
        th = 2.0 * math.pi * i / SEG
        s = math.sin(ph)
        return add(c, mul(add(add(mul(u, s * math.cos(th)), mul(v, s * math.sin(th))), mul(w, math.cos(ph))), rad))

    tris = []
    for j in range(SPHERE_RINGS):
        for i in range(SEG):
            a, b, e, f = pt(j, i), pt(j + 1, i), pt(j + 1, i + 1), pt(j, i + 1)
            for t in ((a, b, e), (a, e, f)):
                if tri_area(*t) > 1e-12 * rad * rad:
                    tris.append((t[0], t[2], t[1]) if inward else t)
    return tris


def tessellate(typ, r):
    if typ == "polygon":
        return polygon(r)[0]
    if typ in ("sphere", "bubble"):
        return sphere(tuple(r[0:3]), r[3], typ == "bubble")
    if typ in ("cylinder", "tube"):
        return cone_like(tuple(r[0:3]), tuple(r[3:6]), r[6], r[6], typ == "tube")
    if typ in ("cone", "cup"):
        return cone_like(tuple(r[0:3]), tuple(r[3:6]), r[6], r[7], typ == "cup")
    if typ == "ring":
        return ring(tuple(r[0:3]), tuple(r[3:6]), r[6], r[7])
    raise ValueError(typ)


# ----------------------------------------------------------------------------------------
def picture_mean(path):
    """Mean RGB of a Radiance picture (file values, as colorpict uses them)."""
    out = subprocess.run(["pvalue", "-h", "-H", "-d", path], check=True,
                         capture_output=True, text=True).stdout.split()
    vals = [float(x) for x in out]
    n = len(vals) // 3
    return tuple(sum(vals[k::3]) / n for k in range(3))


def find_on_raypath(name, dirs):
    for d in dirs:
        p = os.path.join(d, name)
        if os.path.exists(p):
            return p
    return None


def export_from_git(git_dir, dest):
    data = subprocess.run(["git", "--git-dir", git_dir, "archive", "auxiliary", "obj/office"]
                          + ["lib/" + f for f in LIB_FILES], check=True, capture_output=True).stdout
    with tarfile.open(fileobj=io.BytesIO(data)) as tf:
        tf.extractall(dest)
    commit = subprocess.run(["git", "--git-dir", git_dir, "rev-parse", "auxiliary"], check=True,
                            capture_output=True, text=True).stdout.strip()
    return os.path.join(dest, "obj", "office"), os.path.join(dest, "lib"), commit


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--office", help="directory holding the office's scene files (obj/office)")
    ap.add_argument("--lib", help="directory with woodpat.cal weave.cal picture.cal helvet.fnt page*.txt pine.hdr")
    ap.add_argument("--git-dir", help="git dir of a LBNL-ETA/Radiance mirror (branch auxiliary)")
    ap.add_argument("--out", default="scenes", help="output directory (office.obj.gz, office.mtl)")
    ap.add_argument("--rad", help="also write the triangles as a Radiance scene here")
    ap.add_argument("--expanded", help="also keep the xform -e output here")
    args = ap.parse_args()

    tmp = tempfile.mkdtemp(prefix="rad2obj.")
    try:
        if args.git_dir:
            office, lib, commit = export_from_git(args.git_dir, tmp)
            print("exported auxiliary @ %s" % commit)
        elif args.office and args.lib:
            office, lib = args.office, args.lib
        else:
            ap.error("give --office and --lib, or --git-dir")
        # the scene asks for pine.pic; the distribution ships it as pine.hdr
        libtmp = os.path.join(tmp, "libextra")
        os.makedirs(libtmp, exist_ok=True)
        if not os.path.exists(os.path.join(lib, "pine.pic")) and os.path.exists(os.path.join(lib, "pine.hdr")):
            os.symlink(os.path.abspath(os.path.join(lib, "pine.hdr")), os.path.join(libtmp, "pine.pic"))
        raypath = [".", os.path.abspath(lib), libtmp] + [p for p in os.environ.get("RAYPATH", "").split(":") if p]
        env = dict(os.environ, RAYPATH=":".join(raypath))
        expanded = subprocess.run(["xform", "-e"] + SCENE_FILES, cwd=office, env=env, check=True,
                                  capture_output=True, text=True).stdout
        if args.expanded:
            with open(args.expanded, "w") as f:
                f.write(expanded)
        prims = parse(expanded)
        search = [os.path.abspath(office)] + raypath[1:]
        write_outputs(prims, args, search)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def write_outputs(prims, args, search):
    mods = {}                        # name -> (typ, mod, sargs, rargs), latest definition wins
    out_mats = OrderedDict()         # output name -> (kd, ke)
    mat_key = {}                     # (kind, kd, ke, base name) -> output name
    tris_by_mat = OrderedDict()
    prim_count, skipped, simplified = Counter(), Counter(), OrderedDict()
    area_issues = []

    def resolve(modname):
        chain, m = [], modname
        while m != "void":
            if m not in mods:
                raise SystemExit("undefined modifier " + m)
            typ, nxt, sargs, rargs = mods[m]
            chain.append((m, typ, sargs, rargs))
            if typ.startswith("mix") and sargs and sargs[0] != "void":
                m = sargs[0]          # mixfunc/mixdata/mixpict/mixtext: keep the foreground
                continue
            if typ in MATERIAL_TYPES:
                # a material's own modifier is a pattern applied to it
                while nxt != "void":
                    t2, n2, s2, r2 = mods[nxt]
                    chain.append((nxt, t2, s2, r2))
                    nxt = n2
                return chain
            m = nxt
        raise SystemExit("modifier chain of %s has no material" % modname)

    def material_for(modname):
        chain = resolve(modname)
        mat = [c for c in chain if c[1] in MATERIAL_TYPES][0]
        pats = [c for c in chain if c[1] not in MATERIAL_TYPES]
        name, typ, sargs, rargs = mat
        if typ in DROPPED_MATS:
            return None, "%s %s (dropped)" % (typ, name)
        if typ in DIFFUSE_MATS or typ in GREY_MATS:
            kd, ke = tuple(rargs[0:3]), (0.0, 0.0, 0.0)
        elif typ in EMITTER_MATS:
            kd, ke = (0.0, 0.0, 0.0), tuple(rargs[0:3])
        else:
            return None, "%s %s (unsupported material)" % (typ, name)
        for pname, ptyp, psargs, _ in pats:
            note = "%s %s on %s %s" % (ptyp, pname, typ, name)
            if ptyp == "colorpict" and len(psargs) >= 4:
                pic = find_on_raypath(psargs[3], search)
                if pic and os.path.exists(pic):
                    mean = picture_mean(pic)
                    kd = tuple(kd[k] * mean[k] for k in range(3))
                    note += ": mean colour of %s = %.4f %.4f %.4f used" % ((psargs[3],) + mean)
                else:
                    note += ": picture not found, material colour used"
            else:
                note += ": dropped, material colour used"
            simplified[note] = simplified.get(note, 0) + 1
        if typ in GREY_MATS:
            simplified["mirror %s: grey diffuse" % name] = 1
        kd = tuple(round(min(max(x, 0.0), KD_MAX), 4) for x in kd)
        ke = tuple(round(x, 4) for x in ke)
        key = (kd, ke, name)
        if key not in mat_key:
            out = name
            k = 2
            while out in out_mats:
                out = "%s_%d" % (name, k)
                k += 1
            mat_key[key] = out
            out_mats[out] = (kd, ke, typ)
        return mat_key[key], None

    for mod, typ, name, sargs, rargs in prims:
        if typ not in SURFACES:
            if typ in ("instance", "mesh", "source", "antimatter"):
                skipped["%s %s" % (typ, name)] += 1
                continue
            mods[name] = (typ, mod, sargs, rargs)
            continue
        mname, why = material_for(mod)
        if mname is None:
            skipped["%s %s: %s" % (typ, name, why)] += 1
            continue
        tris = tessellate(typ, rargs)
        if typ == "polygon":
            pts = [tuple(rargs[i:i + 3]) for i in range(0, len(rargs), 3)]
            want = 0.5 * norm(newell(pts))
            got = sum(tri_area(*t) for t in tris)
            if abs(got - want) > 1e-6 * max(want, 1e-12) + 1e-9:
                area_issues.append("%s: polygon area %.6g, triangles %.6g" % (name, want, got))
        prim_count[typ] += 1
        tris_by_mat.setdefault(mname, []).extend(tris)

    # ---- OBJ (shared vertices by their printed coordinates) ----
    vidx, vlines, flines = {}, [], []
    ntri, ndegen = Counter(), 0
    for mname, tris in tris_by_mat.items():
        flines.append("usemtl " + mname)
        for t in tris:
            ids = []
            for p in t:
                s = "v %.5f %.5f %.5f" % tuple(x * SCALE + 0.0 for x in p)
                s = s.replace("-0.00000", "0.00000")
                if s not in vidx:
                    vidx[s] = len(vlines) + 1
                    vlines.append(s)
                ids.append(vidx[s])
            if len(set(ids)) < 3:
                ndegen += 1
                continue
            flines.append("f %d %d %d" % tuple(ids))
            ntri[mname] += 1
    os.makedirs(args.out, exist_ok=True)
    text = "mtllib office.mtl\n" + "\n".join(vlines) + "\n" + "\n".join(flines) + "\n"
    with open(os.path.join(args.out, "office.obj.gz"), "wb") as f:
        with gzip.GzipFile(filename="", mode="wb", compresslevel=9, fileobj=f, mtime=0) as g:
            g.write(text.encode())
    with open(os.path.join(args.out, "office.mtl"), "w") as f:
        f.write("# Greg Ward's office (Radiance distribution), converted by scenes/tools/rad2obj.py\n")
        for mname, (kd, ke, typ) in out_mats.items():
            if ntri[mname] == 0:
                continue
            f.write("\nnewmtl %s\nKd %.4f %.4f %.4f\nKe %.4f %.4f %.4f\n" % ((mname,) + kd + ke))

    if args.rad:
        with open(args.rad, "w") as f:
            for mname, (kd, ke, typ) in out_mats.items():
                if any(ke):
                    f.write("void light %s 0 0 3 %g %g %g\n" % ((mname,) + ke))
                else:
                    f.write("void plastic %s 0 0 5 %g %g %g 0 0\n" % ((mname,) + kd))
            verts = [tuple(float(x) for x in s.split()[1:]) for s in vlines]
            cur, n = None, 0
            for line in flines:
                if line.startswith("usemtl"):
                    cur = line.split()[1]
                    continue
                ids = [int(x) for x in line.split()[1:]]
                n += 1
                f.write("%s polygon t%d 0 0 9 %s\n" % (cur, n, " ".join(
                    "%.5f %.5f %.5f" % verts[i - 1] for i in ids)))

    # ---- summary ----
    print("primitives converted:")
    for t in sorted(prim_count):
        print("  %-9s %4d" % (t, prim_count[t]))
    print("triangles per material:")
    for mname, (kd, ke, typ) in out_mats.items():
        if ntri[mname]:
            print("  %-18s %6d  %-8s Kd %s Ke %s" % (mname, ntri[mname], typ,
                  " ".join("%g" % x for x in kd), " ".join("%g" % x for x in ke)))
    print("total triangles: %d, vertices: %d, dropped after rounding: %d" % (sum(ntri.values()), len(vlines), ndegen))
    print("skipped:")
    for s, c in skipped.items():
        print("  %s x%d" % (s, c))
    print("simplified (pattern/texture -> material colour):")
    for s, c in simplified.items():
        print("  %s x%d" % (s, c))
    for s in area_issues:
        print("  AREA MISMATCH " + s)


if __name__ == "__main__":
    main()
