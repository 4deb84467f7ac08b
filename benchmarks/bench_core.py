"""Round-trip errors and speed of the motion core on the shared real BVH files.

    python benchmarks/bench_core.py [--shared ../shared/data]

Prints, per file: BVH read -> write -> read error, canonical -> skeleton -> canonical retarget
error, and the representation's encode -> decode error after integrating the root.
"""
from __future__ import annotations

import argparse
import tarfile
import time
from pathlib import Path

import torch

from motioncore.bvh import format_bvh, parse_bvh, read_bvh
from motioncore.motion import resample
from motioncore.representation import decode, encode, facing_angle
from motioncore.retarget import from_canonical, make_rig, place_on_floor, to_canonical


def errors(motion, name):
    t0 = time.time()
    again, _ = parse_bvh(format_bvh(motion[0], motion[1]), name)
    bvh_err = (again.global_positions() - motion[0].global_positions()).norm(dim=-1).max().item()
    rig = make_rig(motion[0].skeleton, motion[0], source=name)
    canon = place_on_floor(to_canonical(resample(motion[0], 20.0), rig))
    back = to_canonical(from_canonical(canon, rig), rig)
    rt_err = (back.global_positions() - canon.global_positions()).norm(dim=-1).max().item()
    p = canon.global_positions()[:1].double()
    dec = decode(encode(canon), start_yaw=float(facing_angle(p)[0]), start_xz=(float(p[0, 0, 0]), float(p[0, 0, 2])))
    rep_err = (dec.global_positions() - canon.global_positions()).norm(dim=-1).max().item()
    return rig.map_name, canon.duration, bvh_err, rt_err, rep_err, time.time() - t0


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--shared", type=Path, default=Path(__file__).resolve().parents[2] / "shared" / "data")
    args = ap.parse_args()
    torch.set_num_threads(1)
    rows = []
    files = sorted((args.shared / "xia_test").glob("*.bvh")) + sorted((args.shared / "bvh_misc").glob("*.bvh"))
    for f in files:
        rows.append((f.name, *errors(read_bvh(f), f.name)))
    with tarfile.open(args.shared / "bandai2.tar.xz") as tar:
        n = 0
        for m in tar:
            if m.name.endswith(".bvh") and n < 5:
                text = tar.extractfile(m).read().decode()
                rows.append((Path(m.name).name, *errors(parse_bvh(text, m.name), m.name)))
                n += 1
            if n >= 5:
                break
    print(f"{'file':45s} {'skeleton':18s} {'secs':>6s} {'bvh rt mm':>10s} {'retarget rt mm':>15s} {'repr rt mm':>11s} {'time s':>7s}")
    for name, sk, dur, a, b, c, t in rows:
        print(f"{name:45s} {sk:18s} {dur:6.1f} {a * 1000:10.4f} {b * 1000:15.4f} {c * 1000:11.4f} {t:7.2f}")
    print(f"max: bvh {max(r[3] for r in rows) * 1000:.4f} mm, retarget {max(r[4] for r in rows) * 1000:.4f} mm, "
          f"representation {max(r[5] for r in rows) * 1000:.4f} mm")


if __name__ == "__main__":
    main()
