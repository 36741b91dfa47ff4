#!/usr/bin/env python3
# Seam optimisation before/after (docs/pipeline.md, Seams): perturbs the clicks of a `montage synth` scene
# with seeded Gaussian noise (NOISE_PHOTO=1,3 limits it to those photos), runs variants of the options
# (geo: seamRounds 0; seams: defaults; grad: gradientWeight 0.3; *_nolevel: seam levelling off) and
# prints eval's seam Delta E between photos, covered PSNR, L-inf stretch, the stage's figures and times.
# Usage: scripts/seams_measure.py SCENE_DIR TRUTH_MESH TRUTH_TEXTURE [noise_px] [variants]
import json, os, random, subprocess, sys, time, resource
scene, mesh, tex = sys.argv[1], sys.argv[2], sys.argv[3]
noise = float(sys.argv[4]) if len(sys.argv) > 4 else 1.5
variants = sys.argv[5].split(',') if len(sys.argv) > 5 else ['geo', 'seams']
M = os.environ.get('MONTAGE', 'build/bin/montage')
p = json.load(open(os.path.join(scene, 'project.json')))
rng = random.Random(5)
only = os.environ.get('NOISE_PHOTO')
for pt in p['points']:
    for at in pt['at']:
        if only is not None and str(at['photo']) not in only.split(','): continue
        at['x'] += rng.gauss(0, noise); at['y'] += rng.gauss(0, noise)
opts = {'geo': {'seamRounds': 0}, 'seams': {}, 'grad': {'gradientWeight': 0.3},
        'geo_nolevel': {'seamRounds': 0, 'seamLevelling': 'off'}, 'seams_nolevel': {'seamLevelling': 'off'}}
for name in variants:
    q = json.loads(json.dumps(p)); q['options'].update(opts[name])
    pj = os.path.join(scene, f'noisy_{name}.json'); json.dump(q, open(pj, 'w'), indent=1)
    out = os.path.join(scene, f'out_{name}')
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN); t0 = time.time()
    subprocess.run([M, 'run', pj, '--out', out], check=True, stdout=subprocess.DEVNULL)
    wall = time.time() - t0; r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    subprocess.run([M, 'eval', '--result', os.path.join(out, 'model.obj'), '--truth', mesh, '--truth-texture', tex,
                    '--json', os.path.join(out, 'eval.json')], check=True, stdout=subprocess.DEVNULL)
    ev = json.load(open(os.path.join(out, 'eval.json')))
    rep = json.load(open(os.path.join(out, 'report.json')))
    st = {s['stage']: s for s in rep['stages']}
    sm = st['seams']['counts']
    print(f"{os.path.basename(scene)} {name:14s} photoSeamDE {ev.get('photo_seam_mismatch'):.2f} ({ev.get('photo_seam_edges')} edges) "
          f"PSNRcov {ev.get('psnr_covered'):.2f} Linf {ev.get('stretch_linf'):.2f} | seams stage {st['seams']['seconds']:.2f}s "
          f"dE {sm['delta_e_before']:.2f}->{sm['delta_e_after']:.2f} maxS {sm['max_stretch_before']:.2f}->{sm['max_stretch_after']:.2f} "
          f"rounds {sm['rounds']} moved {sm['moved_sides']}/{sm['seam_vertices']} | run wall {wall:.1f}s cpu {cpu:.1f}s load {os.getloadavg()[0]:.2f}", flush=True)
