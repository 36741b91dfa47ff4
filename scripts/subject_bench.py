#!/usr/bin/env python3
"""Photos of another subject with a known truth (issue 33), as a markdown table.

For each mesh and deformation kind: `montage synth --deform KIND` (seed 1, the solid pattern of the undeformed
mesh, photos of the deformed copy, clicks on the undeformed mesh), `montage run` (export on the refined mesh, so
that eval can tell photo faces from inpainted ones; timed, wall), `montage eval --oracle` (the true
correspondence: the undeformed mesh textured through the deformed mesh and the true cameras). The oracle depends
only on the photos (mesh, kind, seed, size), so it is evaluated once per mesh and kind and its figures reused for
the other feature counts and noise levels. Prints one row per scene; the raw figures go to OUT/results.json.

"seen inpainted %" is the share of what the photos see (the oracle's photo-covered surface) that the result
inpaints: (result inpainted − oracle inpainted) / (1 − oracle inpainted), assuming the result's inpainted part
holds what no photo sees (it cannot map it). Covered figures are over each model's own photo-covered samples.

Usage: scripts/subject_bench.py [--montage build/bin/montage] [--data ../shared/data] [--out /tmp/tm_subject_bench]
       [--meshes spot,bob,turtle] [--kinds bend,twist,scale,limbs,turn] [--features 120] [--noise 0,1]
       [--views 3] [--size 1024] [--full] [--lock]
The default (3 meshes, 5 kinds, 120 features, exact and 1 px clicks: 30 scenes) takes about 3 minutes on the
2-core machine; --full is the whole sweep, features 60,120,240 (90 scenes, about 3 x as long). Run it whole under
the machine-wide build lock (flock /tmp/tm-build.lock scripts/subject_bench.py); --lock instead takes the lock for
each command, which lets other jobs in between (the default sweep then took 25 minutes on a busy day), and its
"run s" then includes the wait.
"""
import argparse
import json
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
MESHES = {
    "spot": "meshes/spot/spot_triangulated.obj",
    "bob": "meshes/bob/bob_tri.obj",
    "turtle": os.path.join(HERE, "..", "tests", "data", "turtle.obj"),
}


def run(cmd, lock):
    if lock:
        cmd = ["flock", "/tmp/tm-build.lock"] + cmd
    start = time.monotonic()
    done = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if done.returncode != 0:
        sys.exit("failed: " + " ".join(cmd) + "\n" + done.stdout)
    return time.monotonic() - start


def error_table(rows, out):
    """Where the error goes, per scene: the share of the result's squared colour error on the samples it inpaints
    (from its PSNR over all and over photo-covered samples), the worst share of a photo's faces its warp folds
    (of the photos that took the warp),
    and the leave-one-out error of the photos' maps at their clicks (report.json's subjects: held_out_median_px,
    the median over the photos), against the camera's median residual (the displacement the warp carries)."""
    print("\n| mesh | deform | features | noise px | squared error on inpainted samples % | chosen warp folds % (worst photo) "
          "| click held out: median px | camera residual: median px |")
    print("|---|---|---|---|---|---|---|---|")
    for row in rows:
        r = row["result"]
        mse_all, mse_cov = 10 ** (-r["psnr_all"] / 10), 10 ** (-r["psnr_covered"] / 10)
        share_cov = r["covered_samples"] / max(1, r["samples"])
        inpainted_error = max(0.0, 1 - share_cov * mse_cov / mse_all)
        d = os.path.join(out, f"{row['mesh']}_{row['kind']}_{row['features']}_{row['noise']:g}")
        with open(d + "/out/report.json") as f:
            report = json.load(f)
        subjects = [c for st in report.get("stages", []) if st["stage"] == "projection"
                    for c in st.get("counts", {}).get("subjects", [])]
        folds = max([c["warp_folds"] / max(1, c["warp_faces"]) for c in subjects if c["map"] == "camera and warp"] or [0])
        held = sorted(c["held_out_median_px"] for c in subjects if c.get("held_out_median_px", -1) >= 0)
        resid = sorted(c.get("residual_median_px", 0) for c in report.get("cameras", []))
        med = lambda v: v[len(v) // 2] if v else float("nan")
        print(f"| {row['mesh']} | {row['kind']} | {row['features']} | {row['noise']:g} | {100 * inpainted_error:.0f} "
              f"| {100 * folds:.1f} | {med(held):.1f} | {med(resid):.1f} |")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--montage", default="build/bin/montage")
    ap.add_argument("--data", default="../shared/data")
    ap.add_argument("--out", default="/tmp/tm_subject_bench")
    ap.add_argument("--meshes", default="spot,bob,turtle")
    ap.add_argument("--kinds", default="bend,twist,scale,limbs,turn")
    ap.add_argument("--features", default="120")
    ap.add_argument("--noise", default="0,1")
    ap.add_argument("--views", default="3")
    ap.add_argument("--size", default="1024")
    ap.add_argument("--samples", default="100000")
    ap.add_argument("--full", action="store_true")
    ap.add_argument("--lock", action="store_true")
    ap.add_argument("--errors", action="store_true",
                    help="only print where the error goes, from OUT/results.json and the runs' reports")
    a = ap.parse_args()
    if a.errors:
        with open(os.path.join(a.out, "results.json")) as f:
            error_table(json.load(f), a.out)
        return
    if a.full:
        a.features = "60,120,240"
    rows = []
    start = time.monotonic()
    print("| mesh | deform | features | noise px | photo modes | covered PSNR dB (oracle, gap) "
          "| covered ΔE (oracle, gap) | inpainted % (oracle) | seen inpainted % | flips | run s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for mesh in a.meshes.split(","):
        obj = MESHES[mesh] if os.path.isabs(MESHES[mesh]) else os.path.join(a.data, MESHES[mesh])
        if not os.path.exists(obj):
            sys.exit(obj + " is absent: the table needs the shared data")
        for kind in a.kinds.split(","):
            oracle = None
            for features in a.features.split(","):
                for noise in a.noise.split(","):
                    d = os.path.join(a.out, f"{mesh}_{kind}_{features}_{noise}")
                    run([a.montage, "synth", "--mesh", obj, "--deform", kind, "--views", a.views, "--features",
                         features, "--seed", "1", "--size", a.size, "--click-noise", noise, "--out", d], a.lock)
                    with open(d + "/project.json") as f:
                        project = json.load(f)
                    project.setdefault("options", {})["exportTopology"] = "refined"
                    with open(d + "/project.json", "w") as f:
                        json.dump(project, f, indent=1)
                    wall = run([a.montage, "run", d + "/project.json", "--out", d + "/out"], a.lock)
                    cmd = [a.montage, "eval", "--result", d + "/out/model.obj", "--truth", obj, "--samples",
                           a.samples, "--json", d + "/eval.json"]
                    run(cmd + (["--oracle", d] if oracle is None else []), a.lock)
                    with open(d + "/eval.json") as f:
                        e = json.load(f)
                    if oracle is None:
                        oracle = e["oracle"]
                        r = e["result"]
                    else:
                        r = e
                    with open(d + "/out/report.json") as f:
                        report = json.load(f)
                    # Per photo: "object" (a camera, outliers dropped), "warp" (another subject: camera + warp)
                    # or "paper" (the paper's map).
                    choices = {}
                    for st in report.get("stages", []):
                        for c in st.get("counts", {}).get("subjects", []) if st["stage"] == "projection" else []:
                            choices[c["photo"]] = "warp" if c["map"] == "camera and warp" else "paper"
                    names = []
                    for c in report.get("cameras", []):
                        if c["shows"] == "another subject":
                            names.append(choices.get(c["photo"], "paper"))
                        elif c["fits"]:
                            names.append(f"object −{c['clicks'] - c['inliers']}")
                        else:
                            names.append("paper")
                    modes = " / ".join(names)
                    rin = r["coverage_inpainted"] + r["coverage_empty"]
                    oin = oracle["coverage_inpainted"] + oracle["coverage_empty"]
                    seen = max(0.0, (rin - oin) / max(1e-9, 1 - oin))
                    row = dict(mesh=mesh, kind=kind, features=int(features), noise=float(noise), modes=modes,
                               wall=wall, result=r, oracle=oracle, inpainted=rin, oracle_inpainted=oin,
                               seen_inpainted=seen)
                    rows.append(row)
                    print(f"| {mesh} | {kind} | {features} | {noise} | {modes} "
                          f"| {r['psnr_covered']:.2f} ({oracle['psnr_covered']:.2f}, "
                          f"{r['psnr_covered'] - oracle['psnr_covered']:+.2f}) "
                          f"| {r['delta_e_covered']:.2f} ({oracle['delta_e_covered']:.2f}, "
                          f"{r['delta_e_covered'] - oracle['delta_e_covered']:+.2f}) "
                          f"| {100 * rin:.1f} ({100 * oin:.1f}) | {100 * seen:.1f} "
                          f"| {r['flipped_triangles']} | {wall:.1f} |", flush=True)
    with open(os.path.join(a.out, "results.json"), "w") as f:
        json.dump(rows, f, indent=1)
    error_table(rows, a.out)
    la = os.getloadavg()
    print(f"\n{len(rows)} scenes in {time.monotonic() - start:.0f} s; load average: {la[0]:.2f} {la[1]:.2f} {la[2]:.2f}")


if __name__ == "__main__":
    main()
