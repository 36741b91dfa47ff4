"""What the Blender check scripts share: numpy's bool alias for Blender 3.4's glTF importer, and one line per check."""
import numpy

# Blender 3.4's glTF importer uses numpy.bool, which numpy 1.24 removed.
if "bool" not in numpy.__dict__:
    numpy.bool = bool


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        raise SystemExit(1)
