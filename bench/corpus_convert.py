#!/usr/bin/env python3
# SPDX-License-Identifier: AGPL-3.0-or-later
"""Converts a closed triangulated surface into the corpus's two files.

    corpus_convert.py [--orient] IN OUT.mesh OUT.stl
    corpus_convert.py --diagonal IN     (prints the bounding-box diagonal of IN's points)

IN is OFF (CGAL's data files), gmsh's ASCII MSH 2.2 (.msh: its points,
lines and triangles) or Medit .mesh. Writes Medit .mesh (Vertices + Triangles, reference 1, 1-based) and
ASCII STL (one solid named after OUT, up to its first dot), coordinates as shortest exact
round-trip decimals (Python's repr), facet normals to 9 digits, as
tests/data/README.md describes. Points no triangle uses are dropped, the others
keep their order.

--orient makes the triangles of each connected component consistently
oriented, then outward (positive signed volume): gmsh orients each CAD face on
its own. It fails on an edge that does not have exactly two triangles.
"""
import math
import os
import sys
from collections import defaultdict, deque


def read_off(tokens):
    i = 1 if tokens[0].upper().endswith("OFF") else 0
    nv, nf = int(tokens[i]), int(tokens[i + 1])
    i += 3
    points = []
    for _ in range(nv):
        points.append(tuple(float(x) for x in tokens[i:i + 3]))
        i += 3
    tris = []
    for _ in range(nf):
        k = int(tokens[i])
        face = [int(x) for x in tokens[i + 1:i + 1 + k]]
        i += 1 + k
        for j in range(1, k - 1):  # a polygon as a fan, as pdrmesh reads it
            tris.append((face[0], face[j], face[j + 1]))
    return points, tris


# Medit keywords this reader skips, with the number of values in one record.
MEDIT_SKIP = {"Edges": 3, "Corners": 1, "RequiredVertices": 1, "Ridges": 1, "RequiredEdges": 1,
              "Quadrilaterals": 5, "Tetrahedra": 5, "Normals": 3, "NormalAtVertices": 2}


def read_medit(tokens):
    points, tris = [], []
    i = 0
    while i < len(tokens):
        key = tokens[i]
        if key in ("MeshVersionFormatted", "Dimension"):
            i += 2
        elif key == "Vertices":
            n = int(tokens[i + 1])
            i += 2
            for _ in range(n):
                points.append(tuple(float(x) for x in tokens[i:i + 3]))
                i += 4
        elif key == "Triangles":
            n = int(tokens[i + 1])
            i += 2
            for _ in range(n):
                tris.append(tuple(int(x) - 1 for x in tokens[i:i + 3]))
                i += 4
        elif key in MEDIT_SKIP:
            i += 2 + int(tokens[i + 1]) * MEDIT_SKIP[key]
        elif key == "End":
            break
        else:
            sys.exit(f"corpus_convert: unknown Medit keyword {key!r}")
    return points, tris


def read_msh2(tokens):
    """gmsh's ASCII MSH 2.2: $Nodes and the 3-node triangles (type 2) of $Elements."""
    i = tokens.index("$Nodes") + 1
    index, points = {}, []
    for _ in range(int(tokens[i])):
        index[int(tokens[i + 1])] = len(points)
        points.append(tuple(float(x) for x in tokens[i + 2:i + 5]))
        i += 4
    i = tokens.index("$Elements") + 1
    tris = []
    n = int(tokens[i])
    i += 1
    for _ in range(n):
        kind, tags = int(tokens[i + 1]), int(tokens[i + 2])
        nodes = {1: 2, 2: 3, 15: 1}.get(kind)
        if nodes is None:
            sys.exit(f"corpus_convert: element type {kind} in {tokens[i]}")
        if kind == 2:
            tris.append(tuple(index[int(x)] for x in tokens[i + 3 + tags:i + 6 + tags]))
        i += 3 + tags + nodes
    return points, tris


def compact(points, tris):
    """Drops unused points; the others keep their order."""
    used = sorted({v for t in tris for v in t})
    new = {old: k for k, old in enumerate(used)}
    return [points[v] for v in used], [tuple(new[v] for v in t) for t in tris]


def orient(points, tris):
    """Consistent orientation per connected component, then outward."""
    by_edge = defaultdict(list)
    for k, t in enumerate(tris):
        for a, b in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0])):
            by_edge[(min(a, b), max(a, b))].append(k)
    for e, ts in by_edge.items():
        if len(ts) != 2:
            sys.exit(f"corpus_convert: edge {e} has {len(ts)} triangles")
    tris = [list(t) for t in tris]
    seen = [False] * len(tris)
    for start in range(len(tris)):
        if seen[start]:
            continue
        seen[start] = True
        component, queue = [start], deque([start])
        while queue:
            k = queue.popleft()
            t = tris[k]
            for a, b in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0])):
                other = [j for j in by_edge[(min(a, b), max(a, b))] if j != k][0]
                if seen[other]:
                    continue
                seen[other] = True
                u = tris[other]
                if (a, b) in ((u[0], u[1]), (u[1], u[2]), (u[2], u[0])):
                    u[1], u[2] = u[2], u[1]  # runs the shared edge the same way: flip
                component.append(other)
                queue.append(other)
        volume = 0.0
        for k in component:
            p, q, r = (points[v] for v in tris[k])
            volume += (p[0] * (q[1] * r[2] - q[2] * r[1]) - p[1] * (q[0] * r[2] - q[2] * r[0])
                       + p[2] * (q[0] * r[1] - q[1] * r[0]))
        if volume < 0:
            for k in component:
                tris[k][1], tris[k][2] = tris[k][2], tris[k][1]
    return [tuple(t) for t in tris]


def write_medit(path, points, tris):
    with open(path, "w") as f:
        f.write(f"MeshVersionFormatted 2\nDimension 3\n\nVertices\n{len(points)}\n")
        for p in points:
            f.write(f"{p[0]!r} {p[1]!r} {p[2]!r} 0\n")
        f.write(f"\nTriangles\n{len(tris)}\n")
        for t in tris:
            f.write(f"{t[0] + 1} {t[1] + 1} {t[2] + 1} 1\n")
        f.write("\nEnd\n")


def write_stl(path, name, points, tris):
    with open(path, "w") as f:
        f.write(f"solid {name}\n")
        for t in tris:
            p, q, r = (points[v] for v in t)
            u = [q[i] - p[i] for i in range(3)]
            w = [r[i] - p[i] for i in range(3)]
            n = [u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]]
            length = math.sqrt(sum(c * c for c in n)) or 1.0
            f.write(" facet normal {:.9g} {:.9g} {:.9g}\n  outer loop\n".format(*(c / length for c in n)))
            for v in (p, q, r):
                f.write(f"   vertex {v[0]!r} {v[1]!r} {v[2]!r}\n")
            f.write("  endloop\n endfacet\n")
        f.write(f"endsolid {name}\n")


def main():
    args = sys.argv[1:]
    flags = {a for a in args if a.startswith("--")}
    args = [a for a in args if not a.startswith("--")]
    if flags - {"--orient", "--diagonal"} or len(args) != (1 if "--diagonal" in flags else 3):
        sys.exit(__doc__)
    source = args[0]
    with open(source) as f:  # '#' starts a comment in OFF and Medit files
        tokens = [t for line in f for t in line.split("#", 1)[0].split()]
    suffix = os.path.splitext(source)[1].lower()
    points, tris = {".off": read_off, ".msh": read_msh2}.get(suffix, read_medit)(tokens)
    if "--diagonal" in flags:
        print(repr(math.dist([min(p[i] for p in points) for i in range(3)],
                             [max(p[i] for p in points) for i in range(3)])))
        return
    mesh_out, stl_out = args[1:]
    points, tris = compact(points, tris)
    if "--orient" in flags:
        tris = orient(points, tris)
    write_medit(mesh_out, points, tris)
    write_stl(stl_out, os.path.basename(stl_out).split(".")[0], points, tris)


if __name__ == "__main__":
    main()
