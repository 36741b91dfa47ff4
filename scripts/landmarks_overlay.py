#!/usr/bin/env python3
"""Draw a landmark case (bench/data/*.json, see core/bench/landmarks.h) for checking by eye, and check it.

A generalisation of face_landmarks_overlay.py to any mesh and any view: --view says from which side of the mesh
the photo was taken (front: from +Z, the mesh's facing; right: from -X, the subject's own right when it faces +Z
with +Y up; left: from +X; back: from -Z). Writes, into --out:
  photo.png       the photo, each landmark's pixel marked and labelled (clicks green, held-out yellow,
                  outline-only points cyan, the outline polygon in magenta), magnified around the landmarks;
  mesh_view.png   an orthographic render of the mesh from --view, each landmark's vertex marked and labelled the
                  same way (hollow: hidden behind the surface), the outline's mesh paths in magenta and the faces
                  inside the outline tinted;
  side_by_side.png  the two next to each other.
Checks and prints: the outline's orientation in the photo (counter-clockwise as seen = negative shoelace area in
y-down pixels), that every held-out landmark and every click off the outline lies inside the photo polygon, and
on the mesh the outline's inside as the scorer finds it (faces reached from the clicks off the outline without
crossing a side; sides here are shortest edge paths, an approximation of the tool's), whether every held-out
landmark is inside it, and the share of the inside's area that faces the viewer.

Needs numpy and PIL (use /usr/bin/python3 where a pyenv python lacks them).
Usage: scripts/landmarks_overlay.py --json bench/data/tiger_cat.json --view right [--data ../shared/data]
                                   [--out /tmp/landmarks_check] [--zoom 3]
"""
import argparse, heapq, json, os, sys
try:
    import numpy as np
    from PIL import Image, ImageDraw
except ImportError as e:
    sys.exit(f"{e}: needs numpy and PIL (Debian: python3-numpy python3-pil); try /usr/bin/python3 {sys.argv[0]}")

SKIMAGE_DIRS = ["/usr/lib/python3/dist-packages/skimage/data", "/usr/share/skimage/data"]
VIEWS = {"front": ([1, 0, 0], [0, 1, 0]), "right": ([0, 0, 1], [0, 1, 0]), "left": ([0, 0, -1], [0, 1, 0]),
         "back": ([-1, 0, 0], [0, 1, 0])}
COLOURS = {"click": (0, 230, 0), "heldOut": (255, 220, 0), "outline": (0, 220, 255)}


def photo_path(spec):
    if not spec.startswith("skimage:"):
        return spec
    name = spec.split(":", 1)[1]
    for d in SKIMAGE_DIRS:
        if os.path.exists(os.path.join(d, name)):
            return os.path.join(d, name)
    sys.exit(f"photo {spec}: not found in {SKIMAGE_DIRS} (install python3-skimage)")


def load_obj(path):
    V, F = [], []
    with open(path) as f:
        for line in f:
            if line.startswith("v "):
                V.append([float(a) for a in line.split()[1:4]])
            elif line.startswith("f "):
                idx = [int(a.split("/")[0]) for a in line.split()[1:]]
                idx = [i - 1 if i > 0 else len(V) + i for i in idx]
                for k in range(1, len(idx) - 1):
                    F.append([idx[0], idx[k], idx[k + 1]])
    return np.array(V, float), np.array(F, int)


def weld(V):
    _, first, inv = np.unique(np.round(V, 7), axis=0, return_index=True, return_inverse=True)
    return first[inv.ravel()]  # per vertex: the lowest id at its position


def vertex_normals(V, F, rep):
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    acc = np.zeros((len(V), 3))
    for k in range(3):
        np.add.at(acc, rep[F[:, k]], n)
    acc /= np.linalg.norm(acc, axis=1, keepdims=True) + 1e-12
    return acc[rep]


def render(V, F, rep, right, up, size, lo, hi, tint=None):
    """Orthographic render, screen x along `right`, y along `up`, the viewer on the side of right x up.
    `tint`: per face, 1 to colour it. Returns the image, vertex screen coordinates, depths and the z-buffer."""
    right, up = np.asarray(right, float), np.asarray(up, float)
    toward = np.cross(right, up)
    P = np.stack([V @ right, V @ up, V @ toward], 1)
    s = size / max(hi[0] - lo[0], hi[1] - lo[1])
    sx = (P[:, 0] - lo[0]) * s
    sy = size - (P[:, 1] - lo[1]) * s
    N = vertex_normals(V, F, rep)
    L = np.array([0.3, 0.4, 1.0]); L /= np.linalg.norm(L)
    shade = 0.12 + 0.88 * np.clip(np.stack([N @ right, N @ up, N @ toward], 1) @ L, 0, 1)
    img = np.zeros((size, size)); zb = np.full((size, size), -np.inf); fid = np.full((size, size), -1)
    for f, (a, b, c) in enumerate(F):
        xs, ys, zs = sx[[a, b, c]], sy[[a, b, c]], P[[a, b, c], 2]
        x0, x1 = max(int(xs.min()), 0), min(int(np.ceil(xs.max())), size - 1)
        y0, y1 = max(int(ys.min()), 0), min(int(np.ceil(ys.max())), size - 1)
        if x1 < x0 or y1 < y0:
            continue
        d = (xs[1] - xs[0]) * (ys[2] - ys[0]) - (xs[2] - xs[0]) * (ys[1] - ys[0])
        if abs(d) < 1e-12:
            continue
        X, Y = np.meshgrid(np.arange(x0, x1 + 1) + 0.5, np.arange(y0, y1 + 1) + 0.5)
        w1 = ((X - xs[0]) * (ys[2] - ys[0]) - (xs[2] - xs[0]) * (Y - ys[0])) / d
        w2 = ((xs[1] - xs[0]) * (Y - ys[0]) - (X - xs[0]) * (ys[1] - ys[0])) / d
        w0 = 1 - w1 - w2
        m = (w0 >= -1e-6) & (w1 >= -1e-6) & (w2 >= -1e-6)
        z = w0 * zs[0] + w1 * zs[1] + w2 * zs[2]
        sub = zb[y0:y1 + 1, x0:x1 + 1]
        upd = m & (z > sub)
        sub[upd] = z[upd]
        img[y0:y1 + 1, x0:x1 + 1][upd] = (w0 * shade[a] + w1 * shade[b] + w2 * shade[c])[upd]
        fid[y0:y1 + 1, x0:x1 + 1][upd] = f
    rgb = np.clip(np.stack([img * 0.95, img * 0.85, img * 0.78], 2), 0, 1)
    if tint is not None:
        t = (fid >= 0) & (tint[np.maximum(fid, 0)] > 0)
        rgb[t] = rgb[t] * np.array([0.75, 1.0, 0.75])
    return Image.fromarray((rgb * 255).astype(np.uint8)), sx, sy, P[:, 2], zb, fid


def shortest_path(adj, V, a, b):
    dist, prev, heap = {a: 0.0}, {}, [(0.0, a)]
    while heap:
        d, v = heapq.heappop(heap)
        if v == b:
            break
        if d > dist[v]:
            continue
        for w in adj[v]:
            nd = d + np.linalg.norm(V[v] - V[w])
            if nd < dist.get(w, np.inf):
                dist[w], prev[w] = nd, v
                heapq.heappush(heap, (nd, w))
    path = [b]
    while path[-1] != a:
        path.append(prev[path[-1]])
    return path[::-1]


def outline_inside(V, F, rep, data):
    """The scorer's inside, on the welded mesh: faces reached from the clicks off the outline without crossing a
    side (sides: shortest edge paths between consecutive outline vertices). Returns per-face flags and the paths."""
    Fw = rep[F]
    adj = {}
    edge_faces = {}
    for f, tri in enumerate(Fw):
        for k in range(3):
            a, b = int(tri[k]), int(tri[(k + 1) % 3])
            adj.setdefault(a, set()).add(b); adj.setdefault(b, set()).add(a)
            edge_faces.setdefault((min(a, b), max(a, b)), []).append(f)
    ring = [int(rep[e["vertex"]]) for e in data["outline"]]
    paths, walls = [], set()
    for i in range(len(ring)):
        p = shortest_path(adj, V, ring[i], ring[(i + 1) % len(ring)])
        paths.append(p)
        walls |= {(min(p[k], p[k + 1]), max(p[k], p[k + 1])) for k in range(len(p) - 1)}
    on = set(ring)
    inside = np.zeros(len(F), bool)
    stack = []
    for e in data["clicks"]:
        v = int(rep[e["vertex"]])
        if v in on:
            continue
        for f in np.where((Fw == v).any(1))[0]:
            if not inside[f]:
                inside[f] = True; stack.append(f)
    while stack:
        f = stack.pop()
        tri = Fw[f]
        for k in range(3):
            e = (min(tri[k], tri[(k + 1) % 3]), max(tri[k], tri[(k + 1) % 3]))
            if e in walls:
                continue
            for g in edge_faces[e]:
                if not inside[g]:
                    inside[g] = True; stack.append(g)
    return inside, paths


def in_polygon(p, poly):
    x, y = p; c = False
    for i in range(len(poly)):
        (x1, y1), (x2, y2) = poly[i], poly[(i + 1) % len(poly)]
        if (y1 > y) != (y2 > y) and x < x1 + (y - y1) * (x2 - x1) / (y2 - y1):
            c = not c
    return c


def groups(data):
    clicked = {(e["vertex"], e["x"], e["y"]) for e in data["clicks"]}
    out = [(e, "click") for e in data["clicks"]] + [(e, "heldOut") for e in data["heldOut"]]
    out += [(e, "outline") for e in data["outline"] if (e["vertex"], e["x"], e["y"]) not in clicked]
    return out


def mark(d, x, y, colour, label, r=5, hollow=False):
    d.ellipse([x - r, y - r, x + r, y + r], outline=colour, fill=None if hollow else colour)
    d.line([(x - 2 * r, y), (x + 2 * r, y)], fill=(0, 0, 0))
    d.line([(x, y - 2 * r), (x, y + 2 * r)], fill=(0, 0, 0))
    for ox, oy in ((-1, 0), (1, 0), (0, -1), (0, 1)):
        d.text((x + r + 2 + ox, y - 6 + oy), label, fill=(0, 0, 0))
    d.text((x + r + 2, y - 6), label, fill=colour)


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", default=os.path.join(here, "..", "..", "shared", "data"))
    ap.add_argument("--json", required=True)
    ap.add_argument("--view", choices=sorted(VIEWS), default="front")
    ap.add_argument("--out", default="/tmp/landmarks_check")
    ap.add_argument("--zoom", type=int, default=3)
    args = ap.parse_args()
    data = json.load(open(args.json))
    os.makedirs(args.out, exist_ok=True)
    items = groups(data)
    ok = True

    photo = Image.open(photo_path(data["photo"])).convert("RGBA")
    white = Image.new("RGBA", photo.size, (255, 255, 255, 255)); white.alpha_composite(photo)
    photo = white.convert("RGB")
    xs = [e["x"] for e, _ in items]; ys = [e["y"] for e, _ in items]
    x0, y0 = max(int(min(xs)) - 25, 0), max(int(min(ys)) - 25, 0)
    x1, y1 = min(int(max(xs)) + 25, photo.width), min(int(max(ys)) + 25, photo.height)
    z = args.zoom
    crop = photo.crop((x0, y0, x1, y1)).resize(((x1 - x0) * z, (y1 - y0) * z), Image.LANCZOS)
    d = ImageDraw.Draw(crop)
    pts = [((e["x"] - x0) * z, (e["y"] - y0) * z) for e in data["outline"]]
    d.line(pts + [pts[0]], fill=(255, 0, 255), width=2)
    for e, kind in items:
        mark(d, (e["x"] - x0) * z, (e["y"] - y0) * z, COLOURS[kind], e["name"])
    d.text((5, 5), f"photo crop x {x0}-{x1}, y {y0}-{y1}, x{z}; reference size {data['faceWidth']:g} px",
           fill=(255, 0, 0))
    crop.save(os.path.join(args.out, "photo.png"))

    poly = [(e["x"], e["y"]) for e in data["outline"]]
    on_outline = {(e["vertex"]) for e in data["outline"]}
    for e, kind in items:
        if kind == "heldOut" or (kind == "click" and e["vertex"] not in on_outline):
            if not in_polygon((e["x"], e["y"]), poly):
                print(f"PHOTO: {kind} {e['name']} ({e['x']}, {e['y']}) is outside the outline"); ok = False

    V, F = load_obj(os.path.join(args.data, data["mesh"]))
    rep = weld(V)
    for e, _ in items:
        if not 0 <= e["vertex"] < len(V):
            sys.exit(f"{e['name']}: vertex {e['vertex']} out of range (mesh has {len(V)})")
        if rep[e["vertex"]] != e["vertex"]:
            print(f"{e['name']}: vertex {e['vertex']} is not the lowest id at its position ({rep[e['vertex']]})"); ok = False
    inside, paths = outline_inside(V, F, rep, data)
    r, u = (np.array(a, float) for a in VIEWS[args.view])
    toward = np.cross(r, u)
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    area = 0.5 * np.linalg.norm(n, axis=1)
    facing = (n @ toward) > 0
    Fw = rep[F]
    for e in data["heldOut"]:
        if not inside[(Fw == rep[e["vertex"]]).any(1)].any():
            print(f"MESH: held-out {e['name']} (v{e['vertex']}) is outside the outline's inside"); ok = False
    print(f"mesh: outline's inside {inside.sum()} of {len(F)} faces, {area[inside].sum() / area.sum():.0%} of the "
          f"area; {area[inside & facing].sum() / area[inside].sum():.0%} of it faces the viewer ({args.view})")

    ids = [e["vertex"] for e, _ in items]
    P = V[ids]
    a, b = V @ r, V @ u
    pad = 0.04 * max(np.ptp(a), np.ptp(b))
    lo, hi = (a.min() - pad, b.min() - pad), (a.max() + pad, b.max() + pad)
    size = 1400
    img, sx, sy, depth, zb, _ = render(V, F, rep, r, u, size, lo, hi, tint=inside)
    d = ImageDraw.Draw(img)
    for p in paths:
        vis = [(sx[v], sy[v]) for v in p]
        d.line(vis, fill=(255, 0, 255), width=2)
    eps = 0.01 * max(np.ptp(a), np.ptp(b))
    normals = vertex_normals(V, F, rep)
    for e, kind in items:
        v = e["vertex"]
        X, Y = sx[v], sy[v]
        xi, yi = min(max(int(X), 0), size - 1), min(max(int(Y), 0), size - 1)
        win = zb[max(yi - 1, 0):yi + 2, max(xi - 1, 0):xi + 2]
        win = win[np.isfinite(win)]  # a silhouette vertex: its window holds background and nearer surface
        hidden = win.size > 0 and depth[v] < win.min() - eps and normals[v] @ toward < -0.05
        if hidden:
            print(f"MESH: {kind} {e['name']} (v{v}) is hidden in the {args.view} view"); ok = False
        mark(d, X, Y, COLOURS[kind], e["name"], hollow=hidden)
    d.text((5, 5), f"mesh {data['mesh']}, orthographic from {args.view}: screen x = {r.tolist()}, up = {u.tolist()}; "
           f"green tint: outline's inside; magenta: its sides", fill=(255, 255, 255))
    hgt = int(size - (b.min() - pad - lo[1]) * size / max(hi[0] - lo[0], hi[1] - lo[1]))
    top = int(size - (b.max() + pad - lo[1]) * size / max(hi[0] - lo[0], hi[1] - lo[1]))
    img = img.crop((0, max(top - 20, 0), size, min(hgt + 5, size)))
    img.save(os.path.join(args.out, "mesh_view.png"))
    pa = Image.open(os.path.join(args.out, "photo.png"))
    sc = img.width / pa.width
    both = Image.new("RGB", (pa.width, pa.height + int(img.height / sc)), (255, 255, 255))
    both.paste(pa, (0, 0)); both.paste(img.resize((pa.width, int(img.height / sc))), (0, pa.height))
    both.save(os.path.join(args.out, "side_by_side.png"))

    for e, kind in items:
        p = V[e["vertex"]]
        print(f"{kind:8s} {e['name']:24s} v{e['vertex']:5d} ({p[0]:7.3f},{p[1]:7.3f},{p[2]:7.3f})  "
              f"px ({e['x']:6.1f},{e['y']:6.1f})")
    o = np.array(poly)
    sarea = 0.5 * np.sum(o[:, 0] * np.roll(o[:, 1], -1) - np.roll(o[:, 0], -1) * o[:, 1])
    print(f"outline: {len(o)} points, shoelace area in y-down pixels {sarea:.0f} "
          f"({'counter-clockwise' if sarea < 0 else 'clockwise'} as seen)")
    m = np.array([[V[e['vertex']] @ r, V[e['vertex']] @ u] for e in data["outline"]])
    marea = 0.5 * np.sum(m[:, 0] * np.roll(m[:, 1], -1) - np.roll(m[:, 0], -1) * m[:, 1])
    print(f"outline on the mesh seen from {args.view}: area {marea:.4f} "
          f"({'counter-clockwise' if marea > 0 else 'clockwise'} as seen)")
    print("checks passed" if ok else "CHECKS FAILED")
    print(f"wrote {args.out}/photo.png, mesh_view.png, side_by_side.png")


if __name__ == "__main__":
    main()
