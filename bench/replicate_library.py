#!/usr/bin/env python3
"""Builds a large test library by replicating the clips of an imported library with different
noise seeds: clip k is source clip k % S with gaussian tangent-space-like jitter (seed k) on its
rotations. For memory and throughput measurements (docs/performance.md); the output is not
committed anywhere.

    mocap-clean import ../shared/data/bvh -o cmu.h5
    /usr/bin/python3 bench/replicate_library.py cmu.h5 big.h5 --clips 20000 --max-frames 400
"""
import argparse

import h5py
import numpy as np


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("source")
    p.add_argument("output")
    p.add_argument("--clips", type=int, default=20000)
    p.add_argument("--max-frames", type=int, default=0, help="crop each replica to at most this many frames")
    p.add_argument("--sigma", type=float, default=0.01, help="noise per quaternion component")
    args = p.parse_args()

    src = h5py.File(args.source, "r")
    clips = []
    src["clips"].visititems(lambda name, obj: clips.append(name) if isinstance(obj, h5py.Group) and "rotations" in obj else None)
    clips.sort()
    with h5py.File(args.output, "w", libver=("v108", "latest")) as out:
        for key, value in src.attrs.items():
            out.attrs[key] = value
        src.copy(src["skeletons"], out, "skeletons")
        for k in range(args.clips):
            name = clips[k % len(clips)]
            c = src["clips"][name]
            q = c["rotations"][:]
            t = c["translations"][:]
            if args.max_frames:
                q, t = q[: args.max_frames], t[: args.max_frames]
            rng = np.random.default_rng(k)
            q = q + rng.normal(0.0, args.sigma, q.shape).astype(np.float32)
            q /= np.linalg.norm(q, axis=2, keepdims=True)
            g = out.create_group(f"clips/r{k // 1000:03d}/{name.replace('/', '_')}_{k:06d}")
            for key, value in c.attrs.items():
                g.attrs[key] = value
            chunk = (min(len(q), 1024), q.shape[1], 4)
            g.create_dataset("rotations", data=q, chunks=chunk)
            g.create_dataset("translations", data=t, chunks=(chunk[0], q.shape[1], 3))
    print(f"{args.output}: {args.clips} clips")


if __name__ == "__main__":
    main()
