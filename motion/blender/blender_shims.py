# Debian 12's Blender 3.4 add-ons predate its numpy 1.24 (np.bool) and Python 3.11 (open mode
# "U"); importing this module restores only what those add-ons expect. Imported by the Blender
# scripts (convert.py beside it, the tests' own), before bpy.
import builtins

import numpy

numpy.bool = bool
_open = builtins.open


def _open_without_u(file, mode="r", *args, **kwargs):
    return _open(file, mode.replace("U", ""), *args, **kwargs)


builtins.open = _open_without_u
