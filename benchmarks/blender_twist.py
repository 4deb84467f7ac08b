"""Import two BVH files into Blender (headless) and compare each bone's twist about its own axis.

    blender -b --python benchmarks/blender_twist.py -- INPUT.bvh OUTPUT.bvh

Prints the figure's size in both and the twist difference per bone (swing-twist split of the world
rotation difference about the output bone's axis), sampled on 20 frames. Debian's Blender 3.4 opens
BVH files with mode 'rU', which Python 3.11 refuses; the script strips the 'U'.
"""
import builtins
import math
import sys

import bpy

_open = builtins.open
builtins.open = lambda f, mode="r", *a, **k: _open(f, mode.replace("U", ""), *a, **k)  # Debian's Blender 3.4 importer opens with 'rU'
from mathutils import Quaternion

argv = sys.argv[sys.argv.index("--") + 1:]
def load(path):
    bpy.ops.object.select_all(action='SELECT'); bpy.ops.object.delete()
    bpy.ops.import_anim.bvh(filepath=path, global_scale=0.01, rotate_mode='NATIVE')
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
a = load(argv[0]); fa = bpy.context.scene.frame_end
fr = list(range(1, fa + 1, max(1, fa // 20)))
A = sample(a, fr); heights_a = max(v[1].z for v in A.values()) - min(v[1].z for v in A.values())
b = load(argv[1]); B = sample(b, fr); heights_b = max(v[1].z for v in B.values()) - min(v[1].z for v in B.values())
print("frames", fa, bpy.context.scene.frame_end, f"figure height a/b {heights_a:.2f} {heights_b:.2f} m")
worst = {}
for k, (qa, ha, ta) in A.items():
    qb, hb, tb = B[k]
    axis = (tb - hb).normalized()
    d = qa.rotation_difference(qb)
    # twist about bone axis: project the rotation's vector part on the axis (swing-twist)
    v = d.axis * math.sin(d.angle / 2)
    proj = axis.dot(v)
    tw = Quaternion((d.w, *(axis * proj))).normalized() if abs(d.w) + abs(proj) > 1e-9 else Quaternion()
    ang = math.degrees(2 * math.acos(min(1, abs(tw.w))))
    worst.setdefault(k[1], []).append(ang)
import statistics

allv = sorted(x for v in worst.values() for x in v)
print(f"twist difference deg: median {statistics.median(allv):.1f}, p99 {allv[int(0.99 * (len(allv) - 1))]:.1f}, max {allv[-1]:.1f}")
for n, v in sorted(worst.items(), key=lambda kv: -max(kv[1]))[:5]:
    print(f"  {n:14s} max {max(v):.1f}")
