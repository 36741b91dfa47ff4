#!/usr/bin/env python3
"""Builds the bundled demo (assets/demo/): the CC BY 4.0 cat mesh textured from a real tiger photo.

Inputs (committed in assets/demo/): cat.obj (billyd's cat, remeshed by odedstein/meshes, CC BY 4.0) and
tiger_sumatran_stamp.png (Tux Paint's Sumatran tiger stamp, GPL-2, a photo cut out with alpha).
Outputs (assets/demo/): tiger_left.png + tiger_left_mask.png (the photo, and its foreground mask made
by OpenCV grabCut seeded from the stamp's alpha, with the grass at the feet cut away, and the green cast
of the pale fur white-balanced away),
tiger_right.png + tiger_right_mask.png (the same photo mirrored: the cat's other side), project.json.

Correspondences: 27 landmarks per side were picked by hand, looking at an orthographic side render of
the cat (scripts/make_demo.py --view) next to the photo (the table LANDMARKS below: a mesh vertex,
found by a geometric query so it survives a re-export of the mesh, and its photo pixel). The other body
points are visible mesh vertices spread by farthest-point sampling and placed in the photo by a thin
plate spline through the landmarks; the tail, a separate limb that hangs down in the photo and stands
up on the mesh, is a feature line of tail vertices placed along the photo's tail by arc length; the
head outline is a feature polygon. The other side uses the mirrored photo and the mirrored vertices
(nearest vertex to the reflection across the cat's mid plane z = Z0).

Usage: python3 scripts/make_demo.py [--view CHECK.png]    (needs python3-opencv, python3-scipy)
       python3 scripts/make_demo.py --figure OUT_DEMO      the README picture docs/images/demo.png from
                                                           the renders scripts/demo.sh writes to OUT_DEMO
"""
import json
import os
import sys

import cv2
import numpy as np
from scipy.spatial import cKDTree

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
DEMO = os.path.join(ROOT, "assets", "demo")
Z0 = -0.09  # the cat's mid (sagittal) plane, z = Z0: measured best mirror fit of the mesh onto itself


def load_obj(path):
    V, F = [], []
    for line in open(path):
        if line.startswith("v "):
            V.append([float(x) for x in line.split()[1:4]])
        elif line.startswith("f "):
            F.append([int(x.split("/")[0]) - 1 for x in line.split()[1:4]])
    return np.array(V), np.array(F)


V, F = load_obj(os.path.join(DEMO, "cat.obj"))
N = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
VN = np.zeros_like(V)
for k in range(3):
    np.add.at(VN, F[:, k], N)
VN /= np.linalg.norm(VN, axis=1, keepdims=True) + 1e-12
near = V[:, 2] < Z0  # the side a camera at -z sees (the cat's left side in the photo, head to the right)


def argbest(score, where):
    s = np.where(where, score, -np.inf)
    return int(np.argmax(s))


# The side view of photo A: camera at -z looking at +z, y up, so image right is -x (the head is at x < 0).
def side_uv(p):
    return np.stack([-p[..., 0], p[..., 1]], -1)


x, y = V[:, 0], V[:, 1]
# Hand-picked landmarks of the left side: mesh vertex (by query) -> pixel of tiger_left.png.
LANDMARKS = [
    ("ear tip", argbest(y, (x < 0) & near), (401, 16)),
    # The head, picked on a close-up render with vertex ids (the cat looks up; the tiger ahead).
    ("nose", 4466, (444, 82)),
    ("mouth", 4272, (440, 102)),
    ("chin", 3869, (428, 112)),
    ("throat", 4148, (395, 118)),
    ("top of the head", 4307, (395, 24)),
    ("eye", 5399, (414, 48)),
    ("brow", 4744, (426, 44)),
    ("muzzle", 5000, (432, 80)),
    ("cheek", 5614, (410, 80)),
    ("jaw", 5747, (380, 82)),
    ("inside the ear", 5407, (396, 22)),
    ("neck side", 4043, (352, 75)),
    ("nape", 2358, (340, 18)),
    ("mid back", argbest(y, (np.abs(x - 0.5) < 0.04) & near), (235, 6)),
    ("rump", argbest(y, (np.abs(x - 0.97) < 0.04) & (y < 2.0) & near), (110, 14)),
    ("tail base, rear", argbest(x, (y < 1.9) & (y > 1.7) & near), (63, 40)),
    ("rear paw", argbest(x, (y < 0.1) & near), (62, 166)),
    ("rear heel", argbest(x, (np.abs(y - 0.6) < 0.04) & near), (80, 118)),
    ("front paw tip", argbest(-x, (y < 0.15) & near), (372, 168)),
    ("chest, lowest", argbest(-y, (np.abs(x + 0.16) < 0.05) & near), (318, 136)),
    ("belly, lowest", argbest(-y, (np.abs(x - 0.45) < 0.05) & (y > 0.3) & near), (212, 128)),
    ("flank front of the rear leg", argbest(-y, (np.abs(x - 0.85) < 0.04) & (y > 0.5) & near), (125, 128)),
]
# The photo's tail, base to tip (pixels of tiger_left.png).
TAIL_PHOTO = np.array([(60, 48), (56, 72), (51, 100), (44, 122), (31, 139), (15, 147), (5, 147)], float)


def tps_fit(src, dst, smooth=1e-3):
    """Thin plate spline src -> dst (2D), with a little smoothing."""
    n = len(src)
    d = np.linalg.norm(src[:, None] - src[None], axis=2)
    K = np.where(d > 0, d * d * np.log(d + 1e-300), 0.0) + smooth * np.eye(n)
    P = np.hstack([np.ones((n, 1)), src])
    A = np.zeros((n + 3, n + 3))
    A[:n, :n], A[:n, n:], A[n:, :n] = K, P, P.T
    b = np.zeros((n + 3, 2))
    b[:n] = dst
    w = np.linalg.solve(A, b)

    def apply(q):
        dq = np.linalg.norm(q[:, None] - src[None], axis=2)
        U = np.where(dq > 0, dq * dq * np.log(dq + 1e-300), 0.0)
        return U @ w[:n] + np.hstack([np.ones((len(q), 1)), q]) @ w[n:]

    return apply


def visible_left(S=200.0):
    """Vertices a camera at -z sees (orthographic z-buffer of the side render), facing it."""
    uv = side_uv(V)
    P = (uv - uv.min(0)) * S + 2
    W, H = int(P[:, 0].max()) + 4, int(P[:, 1].max()) + 4
    depth = V[:, 2]
    fd = depth[F].mean(1)
    zbuf = np.full((H, W), np.inf)
    for f in np.argsort(-fd):
        cv2.fillConvexPoly(zbuf, P[F[f]].astype(np.int32), float(fd[f]))
    vis = np.zeros(len(V), bool)
    for i in range(len(V)):
        u, v = int(P[i, 0]), int(P[i, 1])
        vis[i] = depth[i] <= zbuf[max(0, v - 1):v + 2, max(0, u - 1):u + 2].min() + 0.03
    return vis & (VN[:, 2] < -0.35)


def make_mask(rgba):
    """Foreground by grabCut: stamp alpha as the seed, green grass at the feet as probable background."""
    rgb = np.ascontiguousarray(rgba[:, :, :3])
    alpha = rgba[:, :, 3]
    b, g, r = [rgb[:, :, k].astype(int) for k in range(3)]
    rows = np.arange(alpha.shape[0])[:, None] > 0.7 * alpha.shape[0]  # grass grows at the feet only
    green = (g > r + 25) & (g > b + 25) & rows
    mask = np.full(alpha.shape, cv2.GC_BGD, np.uint8)
    mask[alpha > 20] = cv2.GC_PR_FGD
    mask[cv2.erode((alpha > 200).astype(np.uint8), np.ones((7, 7), np.uint8)) > 0] = cv2.GC_FGD
    mask[(alpha > 20) & green] = cv2.GC_PR_BGD
    bgd, fgd = np.zeros((1, 65)), np.zeros((1, 65))
    cv2.grabCut(rgb, mask, None, bgd, fgd, 8, cv2.GC_INIT_WITH_MASK)
    fg = ((mask == cv2.GC_FGD) | (mask == cv2.GC_PR_FGD)) & (alpha > 20)
    # The feet stand in the grass: the grass's blades and a margin round them (grabCut keeps some, as
    # their colour is close to the pale fur's green cast) are cut away.
    fg &= ~cv2.dilate((green & (alpha > 20)).astype(np.uint8), np.ones((5, 5), np.uint8)).astype(bool)
    fg = cv2.morphologyEx(fg.astype(np.uint8), cv2.MORPH_OPEN, np.ones((3, 3), np.uint8)).astype(bool)
    # Keep the largest component (the tiger), drop specks of grass.
    n, lab, stats, _ = cv2.connectedComponentsWithStats(fg.astype(np.uint8))
    if n > 1:
        fg = lab == 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    return (fg * 255).astype(np.uint8)


def main():
    stamp = cv2.imread(os.path.join(DEMO, "tiger_sumatran_stamp.png"), cv2.IMREAD_UNCHANGED)
    H, W = stamp.shape[:2]
    mask = make_mask(stamp)
    # The photo without its cut-out: the stamp's colours over a plain background, as a photo would be.
    a = stamp[:, :, 3:4] / 255.0
    photo = (stamp[:, :, :3] * a + np.array([205, 215, 220]) * (1 - a)).astype(np.uint8)
    # The stamp's pale fur (belly, legs, chest) carries the grass's green cast; a photographer would
    # white-balance it away: a* < 0 (green) of the foreground pulled to a quarter.
    lab = cv2.cvtColor(photo, cv2.COLOR_BGR2Lab).astype(np.float32)
    cast = (mask > 0) & (lab[:, :, 1] < 128)
    lab[:, :, 1][cast] = 128 + 0.25 * (lab[:, :, 1][cast] - 128)
    photo = cv2.cvtColor(np.clip(lab, 0, 255).astype(np.uint8), cv2.COLOR_Lab2BGR)
    cv2.imwrite(os.path.join(DEMO, "tiger_left.png"), photo)
    cv2.imwrite(os.path.join(DEMO, "tiger_left_mask.png"), mask)
    cv2.imwrite(os.path.join(DEMO, "tiger_right.png"), photo[:, ::-1])
    cv2.imwrite(os.path.join(DEMO, "tiger_right_mask.png"), mask[:, ::-1])
    inside = cv2.erode(mask, np.ones((5, 5), np.uint8)) > 0

    lm_v = np.array([v for _, v, _ in LANDMARKS])
    lm_p = np.array([p for _, _, p in LANDMARKS], float)
    tps = tps_fit(side_uv(V[lm_v]), lm_p)

    vis = visible_left()
    tail = (y > 1.95) & (x > 0.85)
    body = vis & ~tail & (y > 0.02)
    # Farthest-point sampling of body vertices, starting from the landmarks.
    chosen = list(lm_v)
    cand = np.flatnonzero(body)
    d = np.min(np.linalg.norm(V[cand][:, None] - V[lm_v][None], axis=2), axis=1)
    while len(chosen) < 140:
        k = int(np.argmax(d))
        if d[k] < 0.085:
            break
        chosen.append(int(cand[k]))
        d = np.minimum(d, np.linalg.norm(V[cand] - V[cand[k]], axis=1))
    pos = {int(v): tuple(p) for v, p in zip(lm_v, lm_p)}
    mapped = tps(side_uv(V[chosen[len(lm_v):]]))
    for v, p in zip(chosen[len(lm_v):], mapped):
        u, w = int(round(p[0])), int(round(p[1]))
        if 0 <= u < W and 0 <= w < H and inside[w, u]:
            pos[int(v)] = (float(p[0]), float(p[1]))

    # Tail line: near-side tail vertices at even heights, to the photo's tail by arc length.
    heights = np.linspace(1.95, V[tail, 1].max(), 6)
    tail_v = []
    for h in heights:
        band = tail & (np.abs(y - h) < 0.06)
        tail_v.append(argbest(-V[:, 2], band))
    seg = np.linalg.norm(np.diff(TAIL_PHOTO, axis=0), axis=1)
    cum = np.concatenate([[0], np.cumsum(seg)])
    for t, v in zip(np.linspace(0, 1, len(tail_v)), tail_v):
        s = t * cum[-1]
        i = min(int(np.searchsorted(cum, s, side="right")) - 1, len(seg) - 1)
        f = (s - cum[i]) / seg[i]
        pos[v] = tuple((1 - f) * TAIL_PHOTO[i] + f * TAIL_PHOTO[i + 1])

    # The other side: mirrored vertices in the mirrored photo.
    R = V.copy()
    R[:, 2] = 2 * Z0 - R[:, 2]
    _, mirror = cKDTree(V).query(R)

    head = ["top of the head", "nose", "chin", "throat", "neck side", "nape"]
    head_v = [v for name in head for n, v, _ in LANDMARKS if n == name]
    # Points of the chains first: a document cut short from the end (tests do) keeps its chains.
    order = list(tail_v) + list(head_v) + [v for v in pos if v not in tail_v and v not in head_v]
    points, index = [], {}
    for photo, flip in ((0, False), (1, True)):
        for v in order:
            px, py = pos[v]
            mv = int(mirror[v]) if flip else int(v)
            if mv in index and any(a["photo"] == photo for a in points[index[mv]]["at"]):
                continue
            if mv not in index:
                index[mv] = len(points)
                points.append({"vertex": mv, "at": []})
            points[index[mv]]["at"].append({"photo": photo, "x": round(W - px if flip else px, 2), "y": round(py, 2)})
    first = {int(v) for v in list(tail_v) + list(head_v)} | {int(mirror[v]) for v in list(tail_v) + list(head_v)}
    points.sort(key=lambda p: p["vertex"] not in first)  # stable: chain points of both photos first
    index = {p["vertex"]: i for i, p in enumerate(points)}
    chains = []
    for photo, flip in ((0, False), (1, True)):
        vv = lambda v: int(mirror[v]) if flip else int(v)
        chains.append({"photo": photo, "points": [index[vv(v)] for v in tail_v], "closed": False})
        chains.append({"photo": photo, "points": [index[vv(v)] for v in head_v], "closed": True})
    project = {
        "format": "texturemontage-project",
        "version": 1,
        "mesh": "cat.obj",
        "photos": [{"path": "tiger_left.png", "mask": "tiger_left_mask.png"},
                   {"path": "tiger_right.png", "mask": "tiger_right_mask.png"}],
        "points": points,
        "chains": chains,
        # The default fill (texture synthesis): the parts no photo covers (tail, paws, chest, back) get
        # tiger fur synthesised from the photo regions mapped nearest them.
        "options": {},
    }
    with open(os.path.join(DEMO, "project.json"), "w") as out:
        json.dump(project, out, indent=2)
        out.write("\n")
    print("wrote %d points (%d with both photos), %d chains to %s" % (
        len(points), sum(len(p["at"]) == 2 for p in points), len(chains), DEMO))
    if len(sys.argv) > 2 and sys.argv[1] == "--view":
        # Landmarks on the photo, for checking by eye.
        big = cv2.resize(photo, None, fx=2, fy=2, interpolation=cv2.INTER_CUBIC)
        for v, (px, py) in pos.items():
            c = (0, 0, 255) if v in lm_v else (255, 0, 0)
            cv2.circle(big, (int(2 * px), int(2 * py)), 3, c, -1)
        cv2.imwrite(sys.argv[2], big)


def figure(out_demo):
    """docs/images/demo.png: the two photos with their mask outlines over four turntable views."""
    views = [cv2.imread(os.path.join(out_demo, "turntable_%02d.png" % k)) for k in (7, 0, 3, 4)]  # near the sides
    # Crop the common margin of background.
    fg = np.any([np.any(np.abs(v.astype(int) - v[0, 0].astype(int)) > 8, axis=2) for v in views], axis=0)
    rows, cols = np.flatnonzero(fg.any(1)), np.flatnonzero(fg.any(0))
    r0, r1, c0, c1 = max(rows[0] - 8, 0), rows[-1] + 9, max(cols[0] - 8, 0), cols[-1] + 9
    views = [v[r0:r1, c0:c1] for v in views]
    w = sum(v.shape[1] for v in views)
    row = []
    for name in ("tiger_left", "tiger_right"):
        photo = cv2.imread(os.path.join(DEMO, name + ".png"))
        mask = cv2.imread(os.path.join(DEMO, name + "_mask.png"), cv2.IMREAD_GRAYSCALE)
        contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
        cv2.drawContours(photo, contours, -1, (255, 0, 255), 1)
        row.append(photo)
    top = np.hstack(row)
    top = cv2.resize(top, (w, int(top.shape[0] * w / top.shape[1])), interpolation=cv2.INTER_CUBIC)
    cv2.imwrite(os.path.join(ROOT, "docs", "images", "demo.png"), np.vstack([top, np.hstack(views)]))


if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[1] == "--figure":
        figure(sys.argv[2])
    else:
        main()
