"""MATLAB's stereoParameters in a MAT-file (versions 5 to 7.0, MATLAB's default '-v7'), read
with scipy.io.loadmat and handed to the MATLAB conventions of core.stereo.importers.matlab.

The file holds either one struct variable with the stereoParameters fields
(`s = toStruct(stereoParams); save('stereo.mat', 's')`) or those fields as variables
(`save('stereo.mat', '-struct', 's')`). A MAT-file 7.3 is HDF5, and a saved stereoParameters
object can be read only by MATLAB: both are refused with what to do.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from core.errors import RoboCalError
from core.stereo.importers.common import ImportedStereo, check_file
from core.stereo.importers.matlab import SAVE_STRUCT, MatlabObject, stereo_from_struct

KIND = "MATLAB stereoParameters (MAT)"
HDF5 = 2          # scipy.io.matlab.matfile_version's major number of a MAT-file 7.3


def _plain(value):
    """A loadmat value (simplify_cells) as JSON-like Python: structs as dicts, numeric arrays as
    nested lists of rows, text as str; MATLAB objects as MatlabObject."""
    from scipy.io import matlab

    if isinstance(value, (matlab.MatlabOpaque, matlab.MatlabObject, matlab.MatlabFunction, matlab.mat_struct)):
        return MatlabObject()
    if isinstance(value, dict):
        return {key: _plain(v) for key, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        if value.dtype.kind == "O":
            return [_plain(v) for v in value.tolist()]
        if value.dtype.names is not None:
            return MatlabObject()
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def load_mat(path: Path) -> dict:
    """The variables of a MAT-file as JSON-like Python (see _plain)."""
    from scipy.io import matlab

    try:
        with path.open("rb") as handle:
            major, _ = matlab.matfile_version(handle)
    except (ValueError, OSError, matlab.MatReadError) as exc:
        raise RoboCalError(f"not a MATLAB MAT-file ({str(exc).strip() or exc.__class__.__name__})", source=path,
                           hint=f"Save the stereo parameters in MATLAB: {SAVE_STRUCT}.") from None
    if major == HDF5:
        raise RoboCalError("a MAT-file version 7.3 (HDF5), which RoboCal cannot read", source=path,
                           hint=f"Save it again as version 7 in MATLAB: {SAVE_STRUCT}.")
    try:
        variables = matlab.loadmat(str(path), simplify_cells=True)
    except Exception as exc:      # scipy raises many kinds on a damaged file (ValueError, zlib.error, …)
        raise RoboCalError(f"not a readable MAT-file ({exc.__class__.__name__})", source=path,
                           hint=f"Save it again in MATLAB: {SAVE_STRUCT}.") from None
    return {name: _plain(v) for name, v in variables.items() if not name.startswith("__")}


def read_matlab_mat(path) -> ImportedStereo:
    """The stereoParameters struct of a MAT-file (one struct variable, or its fields as variables)."""
    path = check_file(Path(path), text=False)
    variables = load_mat(path)
    if "CameraParameters1" in variables:                           # save(..., '-struct', 's')
        return stereo_from_struct(variables, path, KIND)
    found = sorted(name for name, v in variables.items() if isinstance(v, dict) and "CameraParameters1" in v)
    if len(found) == 1:
        return stereo_from_struct(variables[found[0]], path, KIND, prefix=found[0] + ".")
    if found:
        raise RoboCalError(f"holds several stereo calibrations ({', '.join(found)})", source=path,
                           hint="Save one: save('stereo.mat', 's', '-v7').")
    objects = sorted(name for name, v in variables.items() if isinstance(v, MatlabObject))
    if objects:
        raise RoboCalError(f"variable '{objects[0]}' is a MATLAB object, which only MATLAB can read", source=path,
                           hint=f"Save the struct of the stereo parameters instead: {SAVE_STRUCT}.")
    listing = ", ".join(sorted(variables)) or "none"
    raise RoboCalError(f"holds no stereoParameters struct (a struct with CameraParameters1); variables: {listing}",
                       source=path, hint=f"Save the stereo parameters in MATLAB: {SAVE_STRUCT}.")
