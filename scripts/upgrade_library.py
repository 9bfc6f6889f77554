#!/usr/bin/python3
"""Converts a mocap-clean library of format_version 1 into format_version 2.

Version 1 stored its strings (names, sources, provenance) as variable-length strings. Their bytes
live in HDF5's global heap, whose decoding in libhdf5 1.10 crashes or hangs on a damaged file, so
mocap-clean no longer reads them; version 2 stores the same strings as fixed-length UTF-8. The
motion, every other dataset and attribute are copied as they are (chunks, filters, checksums).

Run it only on libraries you trust (your own, written by an older mocap-clean): it reads the
variable-length strings through h5py and the same libhdf5.

usage: scripts/upgrade_library.py OLD.h5 NEW.h5    (NEW.h5 must not exist; written atomically)
"""
import argparse
import os
import sys

import h5py
import numpy as np


def fail(message):
    print(f"upgrade_library.py: {message}", file=sys.stderr)
    sys.exit(1)


def is_variable_string(dtype):
    info = h5py.check_string_dtype(dtype)
    return info is not None and info.length is None


def fixed(values):
    """UTF-8 bytes of `values` (str or bytes) as a fixed-length string array and its dtype."""
    encoded = [v.encode("utf-8") if isinstance(v, str) else bytes(v) for v in values]
    length = max([1] + [len(v) for v in encoded])
    dtype = h5py.string_dtype("utf-8", length)
    return np.array(encoded, dtype=dtype), dtype  # dtype's metadata marks UTF-8 for HDF5


def upgrade_attributes(obj):
    for name in list(obj.attrs):
        attribute = obj.attrs.get_id(name)
        if not is_variable_string(attribute.dtype):
            continue
        value = obj.attrs[name]
        values = np.asarray(value, dtype=object).reshape(-1)
        data, dtype = fixed(values)
        del obj.attrs[name]
        obj.attrs.create(name, data.reshape(np.shape(value)), dtype=dtype)


def upgrade(source, target):
    with h5py.File(source, "r") as src:
        format_name = src.attrs.get("format")
        if isinstance(format_name, bytes):
            format_name = format_name.decode("utf-8", "replace")
        if format_name != "mocap-clean-library":
            fail(f"{source}: not a mocap-clean library (its 'format' attribute is {format_name!r})")
        version = src.attrs.get("format_version")
        if version != 1:
            fail(f"{source}: format_version {version}, not 1: nothing to upgrade")
        with h5py.File(target, "w", libver=("v108", "latest")) as out:
            for name in src:
                src.copy(src[name], out, name)
            for name, value in src.attrs.items():
                out.attrs[name] = value
            objects = [out]
            out.visititems(lambda _, obj: objects.append(obj))
            for obj in objects:
                upgrade_attributes(obj)
                if isinstance(obj, h5py.Dataset) and is_variable_string(obj.dtype):
                    parent, name = obj.parent, obj.name.rsplit("/", 1)[1]
                    data, dtype = fixed(obj.asstr()[()].reshape(-1))
                    shape = obj.shape
                    del parent[name]
                    parent.create_dataset(name, data=data.reshape(shape), dtype=dtype)
            out.attrs.create("format_version", 2, dtype=np.int32)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("old", help="a library of format_version 1")
    parser.add_argument("new", help="the converted library (must not exist)")
    args = parser.parse_args()
    if os.path.lexists(args.new):
        fail(f"{args.new}: exists; give a new path")
    temporary = args.new + ".tmp"
    try:
        upgrade(args.old, temporary)
        os.replace(temporary, args.new)
    except (OSError, KeyError, ValueError) as e:
        fail(f"{args.old}: {e}")
    finally:
        if os.path.exists(temporary):
            os.remove(temporary)
    print(f"{args.new}: format_version 2")
    return 0


if __name__ == "__main__":
    sys.exit(main())
