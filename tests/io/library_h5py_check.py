#!/usr/bin/python3
"""Checks a mocap-clean library file as a user with plain h5py sees it (the layout contract of
shared/spec/architecture.md, "The HDF5 library file"). Prints OK and exits 0, or prints what is
wrong and exits 1. Run by tests/io/library_store_test.cpp.

usage: library_h5py_check.py FILE... --clips a/b,c --skeletons N [--provenance]
"""
import argparse
import sys

import h5py
import numpy as np

problems = []


def check(condition, message):
    if not condition:
        problems.append(message)
    return condition


def text(value):
    """A string attribute as h5py reads it: fixed-length UTF-8 comes as bytes; None otherwise."""
    if not isinstance(value, bytes):
        return None
    try:
        return value.decode("utf-8")
    except UnicodeDecodeError:
        return None


def check_skeleton(name, group):
    where = f"/skeletons/{name}"
    names = group["joint_names"].asstr()[()] if "joint_names" in group else None
    if not check(names is not None and names.ndim == 1, f"{where}: joint_names [J] strings"):
        return
    joints = len(names)
    check(all(isinstance(n, str) for n in names), f"{where}: joint_names are not str")
    parents = group["parents"]
    check(parents.dtype == np.int32 and parents.shape == (joints,), f"{where}: parents int32[J]")
    check(int(parents[0]) == -1, f"{where}: the first joint is not a root")
    check(all(-1 <= int(p) < j for j, p in enumerate(parents[()])), f"{where}: bad parents")
    for rows in ("offsets", "end_sites"):
        data = group[rows]
        check(data.dtype == np.float64 and data.shape == (joints, 3), f"{where}: {rows} f8[J,3]")
    channels = group["channels"].asstr()[()]
    check(channels.shape == (joints,), f"{where}: channels [J]")
    for c in channels:
        for word in c.split():
            check(word in ("Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation",
                           "Zrotation"), f"{where}: unknown channel {word!r}")
    has = group["has_end_site"]
    check(has.dtype == np.uint8 and has.shape == (joints,), f"{where}: has_end_site u8[J]")
    return joints


def check_clip(path, group, skeleton_joints):
    where = f"/clips/{path}"
    skeleton = text(group.attrs.get("skeleton"))
    if not check(skeleton is not None, f"{where}: skeleton attr is not UTF-8 bytes"):
        return
    check(skeleton in skeleton_joints, f"{where}: skeleton {skeleton!r} not in /skeletons")
    check(text(group.attrs.get("source")) is not None, f"{where}: source attr is not UTF-8 bytes")
    frame_time = group.attrs.get("frame_time")
    check(isinstance(frame_time, np.floating) and frame_time > 0, f"{where}: frame_time")
    rotations, translations = group["rotations"], group["translations"]
    joints = skeleton_joints.get(skeleton)
    for data, width in ((rotations, 4), (translations, 3)):
        check(data.dtype == np.float32, f"{data.name}: dtype {data.dtype}, want float32")
        check(data.ndim == 3 and data.shape[1:] == (joints, width),
              f"{data.name}: shape {data.shape}, want [F, {joints}, {width}]")
        check(data.chunks is not None, f"{data.name}: not chunked")
    check(rotations.shape[0] == translations.shape[0], f"{where}: frame counts differ")
    q = rotations[()]  # decompresses (the LZ4 plugin must be found for lz4 files)
    if q.size:
        norms = np.linalg.norm(q.astype(np.float64), axis=2)
        check(np.all(np.abs(norms - 1) < 1e-5), f"{where}: rotations are not unit quaternions")
    check(np.all(np.isfinite(translations[()])), f"{where}: translations not finite")


def check_file(path, args):
    with h5py.File(path, "r") as f:
        check(text(f.attrs.get("format")) == "mocap-clean-library", "root attr format")
        version = f.attrs.get("format_version")
        check(isinstance(version, np.integer) and version == 2, "root attr format_version == 2")
        skeleton_joints = {name: check_skeleton(name, g) for name, g in f["skeletons"].items()}
        check(len(skeleton_joints) == args.skeletons,
              f"{len(skeleton_joints)} skeletons, expected {args.skeletons}")

        clips = []

        def visit(name, obj):
            if isinstance(obj, h5py.Group) and "rotations" in obj:
                clips.append(name)

        f["clips"].visititems(visit)
        check(sorted(clips) == sorted(args.clips.split(",")), f"clips {sorted(clips)}")
        for clip in clips:
            check_clip(clip, f["clips"][clip], skeleton_joints)

        if args.provenance:
            p = f["provenance"].attrs
            for key in ("method", "parameters", "engine_version", "input_file", "created"):
                check(text(p.get(key)) is not None, f"/provenance attr {key} is not UTF-8 bytes")
            check((text(p.get("created")) or "").endswith("Z"), "/provenance created is not UTC")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("files", nargs="+")
    parser.add_argument("--clips", required=True, help="comma-separated expected clip paths")
    parser.add_argument("--skeletons", type=int, required=True)
    parser.add_argument("--provenance", action="store_true")
    args = parser.parse_args()

    failed = 0
    for path in args.files:
        problems.clear()
        check_file(path, args)
        if problems:
            print(f"{path}:\n  " + "\n  ".join(problems))
            failed += 1
    if failed:
        return 1
    print(f"OK ({len(args.files)} files)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
