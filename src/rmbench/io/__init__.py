"""File formats (netCDF datasets, UFF58, CSV): readers and writers that import no stage.

`uff58`: receptance matrices of a campaign to and from UFF58 universal files (METHODS.md §1 nodes).
`uff55`: modal parameters of a modal dataset to UFF55 complex-mode files and a CSV table.
`strict_json`: JSON text any parser reads (NaN and infinity written as null, never bare).
`toolpath`: tool paths (cutter-location CSV, a G-code subset) as :class:`ToolPath`.
`tracker_csv`: laser-tracker readings.
"""

from rmbench.io.strict_json import jsonable, strict_dumps
from rmbench.io.toolpath import ToolPath, read_cl_csv, read_gcode, read_toolpath, write_cl_csv
from rmbench.io.uff55 import write_modal_csv, write_uff55
from rmbench.io.uff58 import DEFAULT_NODE_MAP, LOW_BAND_LIMIT_HZ, read_uff58, write_uff58

__all__ = ["write_uff58", "read_uff58", "DEFAULT_NODE_MAP", "LOW_BAND_LIMIT_HZ",
           "write_uff55", "write_modal_csv", "jsonable", "strict_dumps", "ToolPath", "read_toolpath",
           "read_cl_csv", "read_gcode", "write_cl_csv"]
