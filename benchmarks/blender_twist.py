"""Import two BVH files into Blender (headless) and compare each bone's twist about its own axis.

    blender -b --python benchmarks/blender_twist.py -- INPUT.bvh OUTPUT.bvh [ROLES.json]

ROLES.json: the map ``video2style skeleton INPUT.bvh --write-map ROLES.json`` writes; with it the
role bones are reported apart from the others.

Prints the figure's size in both and the twist difference per bone (swing-twist split of the rotation
from the input bone to the output bone, in the input bone's frame, about the bone's own Y axis),
sampled on 20 frames of the clip. Bones are split into those that play a canonical role and the
rest (fingers, helpers), which follow their parent and so turn with its bend. Debian's Blender 3.4 opens
BVH files with mode 'rU', which Python 3.11 refuses; the script strips the 'U'.
"""
import builtins
import json
import math
import statistics
import sys

import bpy
from mathutils import Quaternion

_open = builtins.open
builtins.open = lambda f, mode="r", *a, **k: _open(f, mode.replace("U", ""), *a, **k)  # Debian's Blender 3.4 importer opens with 'rU'

argv = sys.argv[sys.argv.index("--") + 1:]
def load(path):
    bpy.ops.object.select_all(action='SELECT')
    bpy.ops.object.delete()
    bpy.ops.import_anim.bvh(filepath=path, global_scale=1.0, rotate_mode='NATIVE')  # the importer's default
    ob = next(o for o in bpy.data.objects if o.type == 'ARMATURE')
    return ob
def sample(ob, frames):
    out = {}
    sc = bpy.context.scene
    for f in frames:
        sc.frame_set(f)
        for pb in ob.pose.bones:
            out[(f, pb.name)] = ((ob.matrix_world @ pb.matrix).to_quaternion(), (ob.matrix_world @ pb.head).copy(), (ob.matrix_world @ pb.tail).copy())
    return out
a = load(argv[0])
fa = int(a.animation_data.action.frame_range[1])
fr = list(range(1, fa + 1, max(1, fa // 20)))
A = sample(a, fr)
heights_a = max(v[1].z for v in A.values()) - min(v[1].z for v in A.values())
b = load(argv[1])
B = sample(b, fr)
heights_b = max(v[1].z for v in B.values()) - min(v[1].z for v in B.values())
print("frames", fa, f"figure height a/b {heights_a:.2f} {heights_b:.2f} file units")
worst = {}
for k, (qa, _ha, _ta) in A.items():
    qb, hb, tb = B[k]
    # the difference in the input bone's own frame, where the bone runs along Y; its twist is the part
    # about Y (swing-twist split)
    d = qa.conjugated() @ qb
    tw = Quaternion((d.w, 0.0, d.y, 0.0))
    ang = math.degrees(2 * math.acos(min(1.0, abs(tw.w) / max(tw.magnitude, 1e-12))))
    worst.setdefault(k[1], []).append(ang)
if len(argv) > 2:
    with open(argv[2]) as f:
        roles = {v for v in json.load(f).values() if v}
else:
    roles = set(worst)
for what, names in (("role bones", roles), ("other bones", set(worst) - roles)):
    allv = sorted(x for n in names if n in worst for x in worst[n])
    if not allv:
        continue
    flipped = sum(x > 150 for x in allv)
    print(f"{what}: twist difference deg: median {statistics.median(allv):.1f}, p99 {allv[int(0.99 * (len(allv) - 1))]:.1f}, "
          f"max {allv[-1]:.1f}, flipped (>150) {flipped}")
    for n, v in sorted(((n, worst[n]) for n in names if n in worst), key=lambda kv: -max(kv[1]))[:4]:
        print(f"  {n:14s} max {max(v):.1f}")
