#!/usr/bin/env python3
"""Checks the layering rules of README "Layout" on every source file under ROOT.

  core/     the standard library only
  kernels/  core/ (and Highway), never io/, engine/ or app/
  io/       core/ (and HDF5, nlohmann-json, ...), never kernels/, engine/ or app/
  engine/   core/, kernels/, io/, never app/

Exits 1 naming every include that breaks a rule. `--self-test` first plants one breach of each
rule in a scratch tree and fails unless each is caught, so the check itself can be trusted.
"""
import pathlib
import re
import sys
import tempfile

LAYERS = ("core", "kernels", "io", "engine", "app")
ALLOWED = {
    "core": {"core"},
    "kernels": {"core", "kernels"},
    "io": {"core", "io"},
    "engine": {"core", "kernels", "io", "engine"},
    "app": set(LAYERS),
}
INCLUDE = re.compile(r'^\s*#\s*include\s*([<"])([^>"]+)[>"]')
# Standard C++ headers carry no extension and no folder: <vector>, <cstdint>.
STANDARD = re.compile(r"^[a-z_0-9]+$")


def breaches(root: pathlib.Path):
    found = []
    for layer in LAYERS:
        for path in sorted((root / layer).rglob("*")):
            if path.suffix not in (".hpp", ".cpp", ".h", ".cc"):
                continue
            for number, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
                m = INCLUDE.match(line)
                if not m:
                    continue
                bracket, name = m.groups()
                top = name.split("/", 1)[0]
                where = f"{path.relative_to(root)}:{number}: {layer}/ includes {name}"
                if layer == "core" and bracket == "<" and not STANDARD.match(name):
                    found.append(f"{where} (core/ uses the standard library only)")
                elif top in LAYERS and "/" in name and top not in ALLOWED[layer]:
                    found.append(f"{where} ({layer}/ may include only "
                                 f"{', '.join(sorted(ALLOWED[layer]))})")
                elif layer == "core" and bracket == '"' and top != "core":
                    found.append(f"{where} (core/ uses the standard library only)")
    return found


def self_test() -> bool:
    planted = {
        "core/a.hpp": '#include <hwy/highway.h>\n',
        "core/b.hpp": '#include "kernels/nlpm.hpp"\n',
        "kernels/c.cpp": '#include "io/bvh_reader.hpp"\n',
        "io/d.cpp": '#include "kernels/nlpm.hpp"\n',
        "io/e.cpp": '#include "engine/run/job.hpp"\n',
        "engine/run/f.cpp": '#include "app/cli.hpp"\n',
    }
    fine = {
        "core/ok.hpp": '#include <vector>\n#include "core/tensor.hpp"\n',
        "kernels/ok.cpp": '#include "core/quaternion.hpp"\n#include "hwy/highway.h"\n',
        "io/ok.cpp": '#include "core/clip.hpp"\n#include <hdf5.h>\n',
        "engine/ok.cpp": '#include "io/bvh_reader.hpp"\n#include "kernels/nlpm.hpp"\n',
        "app/ok.cpp": '#include "engine/run/job.hpp"\n',
    }
    with tempfile.TemporaryDirectory() as scratch:
        root = pathlib.Path(scratch)
        for name, text in {**planted, **fine}.items():
            (root / name).parent.mkdir(parents=True, exist_ok=True)
            (root / name).write_text(text)
        found = breaches(root)
    caught = {f.split(":", 1)[0] for f in found}
    missed = sorted(set(planted) - caught)
    false = sorted(caught - set(planted))
    for name in missed:
        print(f"self-test: the planted breach in {name} was not caught")
    for name in false:
        print(f"self-test: {name} was flagged but follows the rules")
    return not missed and not false


def main() -> int:
    args = sys.argv[1:]
    if args and args[0] == "--self-test":
        if not self_test():
            return 1
        args = args[1:]
    root = pathlib.Path(args[0] if args else ".")
    missing = [layer for layer in LAYERS if not (root / layer).is_dir()]
    if missing:
        print(f"{root}: no {', '.join(missing)} folder: not a mocap-clean source tree")
        return 1
    found = breaches(root)
    for f in found:
        print(f)
    print(f"{len(found)} include(s) break the layering rules" if found else
          "layering rules hold")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
