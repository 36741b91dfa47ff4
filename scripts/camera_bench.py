#!/usr/bin/env python3
"""Camera-aware mapping against the projection oracle (issue 11), as a markdown table.

For each mesh, view count, feature count and click noise: `montage synth` (seed 1), `montage run`
(timed: wall and CPU user+sys of the process), `montage eval --oracle` (the scene textured through its
true cameras). Prints one table row per scene; the raw figures go to OUT/results.json. The quality
columns are over the whole surface, and the inpainted share comes from the run's report: the export keeps
the input's topology, so eval's "covered" figures (faces a photo maps in the result file) no longer name
the faces the photos textured.

Usage: scripts/camera_bench.py [--montage build/bin/montage] [--data ../shared/data] [--out /tmp/tm_camera_bench]
       [--meshes spot,bob] [--views 2,4] [--features 50,150,300] [--noise 0,1] [--k1 0] [--size 1024] [--lock]
       [--set KEY=VALUE ...]
--k1 lists lens distortions (synth --k1, every view; the fit's k1 and k2 per photo are in results.json).
--set passes project options to every `montage run` (e.g. --set correction=off); the seen column is the PSNR over
what the oracle's photos see (eval's psnr_seen), the issue-37 measure.
--flatten lays each photo over white and drops its alpha before the run (photos without a cut-out: no silhouette but
the one the camera stage finds around the mesh's outline; the oracle reads the same photos). --background FILE lays
them over that image instead (a cluttered background; every other view mirrored).
--lock runs each command under the machine-wide build lock (flock /tmp/tm-build.lock), as HELPERS.md asks.
"""
import argparse
import json
import os
import resource
import subprocess
import sys
import time

MESHES = {
    "spot": ("meshes/spot/spot_triangulated.obj", "meshes/spot/spot_texture.png"),
    "bob": ("meshes/bob/bob_tri.obj", "meshes/bob/bob_diffuse.png"),
}


def run(cmd, lock):
    if lock:
        cmd = ["flock", "/tmp/tm-build.lock"] + cmd
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.monotonic()
    done = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    wall = time.monotonic() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        sys.exit("failed: " + " ".join(cmd) + "\n" + done.stdout)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def flatten(d, views, background=None):
    """Lays each photo over white, or over `background` (an image file, scaled to the photo, mirrored in every other
    view): a photo without a cut-out, on a plain or a cluttered background."""
    import cv2  # python3-opencv (scripts/setup.sh --with-tools)
    for k in range(views):
        path = os.path.join(d, f"photo_{k}.png")
        rgba = cv2.imread(path, cv2.IMREAD_UNCHANGED)
        alpha = rgba[:, :, 3:4].astype("float32") / 255
        if background:
            under = cv2.resize(cv2.imread(background, cv2.IMREAD_COLOR), (rgba.shape[1], rgba.shape[0]),
                               interpolation=cv2.INTER_AREA).astype("float32")
            if k % 2:
                under = under[:, ::-1]
        else:
            under = 255
        cv2.imwrite(path, (rgba[:, :, :3] * alpha + under * (1 - alpha) + 0.5).astype("uint8"))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--montage", default="build/bin/montage")
    ap.add_argument("--data", default="../shared/data")
    ap.add_argument("--out", default="/tmp/tm_camera_bench")
    ap.add_argument("--meshes", default="spot,bob")
    ap.add_argument("--views", default="2,4")
    ap.add_argument("--features", default="50,150,300")
    ap.add_argument("--noise", default="0,1")
    ap.add_argument("--k1", default="0")
    ap.add_argument("--size", default="1024")
    ap.add_argument("--lock", action="store_true")
    ap.add_argument("--flatten", action="store_true", help="photos without a cut-out: laid over white")
    ap.add_argument("--background", help="photos without a cut-out laid over this image (implies --flatten)")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    a = ap.parse_args()
    rows = []
    print("| mesh | views | features | noise px | k1 (fitted, median) | fitted | PSNR (oracle, gap) dB | ΔE (oracle) "
          "| seen PSNR (oracle, gap) dB | inpainted % (no photo sees) | flips | run s wall / CPU |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for mesh in a.meshes.split(","):
        obj, tex = (os.path.join(a.data, p) for p in MESHES[mesh])
        if not os.path.exists(obj):
            sys.exit(obj + " is absent: the table needs the shared data")
        for views in a.views.split(","):
            for features in a.features.split(","):
                for noise in a.noise.split(","):
                    for k1 in a.k1.split(","):
                        d = os.path.join(a.out, f"{mesh}_{views}_{features}_{noise}" + (f"_k{k1}" if float(k1) else ""))
                        run([a.montage, "synth", "--mesh", obj, "--texture", tex, "--views", views, "--features", features,
                             "--seed", "1", "--size", a.size, "--click-noise", noise, "--k1", k1, "--out", d], a.lock)
                        if a.flatten or a.background:
                            flatten(d, int(views), a.background)
                        sets = [x for kv in a.set for x in ("--set", kv)]
                        wall, cpu = run([a.montage, "run", d + "/project.json", "--out", d + "/out"] + sets, a.lock)
                        run([a.montage, "eval", "--result", d + "/out/model.obj", "--truth", obj, "--truth-texture", tex,
                             "--oracle", d, "--json", d + "/eval.json"], a.lock)
                        e = json.load(open(d + "/eval.json"))
                        report = json.load(open(d + "/out/report.json"))
                        fits = [c for c in report.get("cameras", []) if c["fits"]]
                        fittedK1 = sorted(c.get("k1", 0.0) for c in fits)
                        r, o = e["result"], e["oracle"]
                        row = dict(sets=a.set, mesh=mesh, views=int(views), features=int(features), noise=float(noise), k1=float(k1),
                                   fitted=len(fits), fitted_k1=fittedK1, wall=wall, cpu=cpu, result=r, oracle=o,
                                   unseen=e["unseen_share"], seen=e["psnr_seen"], seen_gap=e["psnr_seen_gap"], inpainted=report["surface"]["inpainted_share"])
                        rows.append(row)
                        medianK1 = fittedK1[len(fittedK1) // 2] if fittedK1 else float("nan")
                        print(f"| {mesh} | {views} | {features} | {noise} | {k1} ({medianK1:+.3f}) | {len(fits)}/{views} "
                              f"| {r['psnr_all']:.2f} ({o['psnr_all']:.2f}, {r['psnr_all'] - o['psnr_all']:+.2f}) "
                              f"| {r['delta_e_all']:.3f} ({o['delta_e_all']:.3f}) "
                              f"| {e['psnr_seen']:.2f} ({o['psnr_seen']:.2f}, {e['psnr_seen_gap']:+.2f}) "
                              f"| {100 * row['inpainted']:.1f} ({100 * row['unseen']:.1f}) "
                              f"| {r['flipped_triangles']} | {wall:.1f} / {cpu:.1f} |", flush=True)
    with open(os.path.join(a.out, "results.json"), "w") as f:
        json.dump(rows, f, indent=1)
    print(f"load average: {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f} {os.getloadavg()[2]:.2f}")


if __name__ == "__main__":
    main()
