"""File formats (netCDF datasets, UFF58, CSV): readers and writers that import no stage.

`uff58`: receptance matrices of a campaign to and from UFF58 universal files (METHODS.md §1 nodes).
"""

from rmbench.io.uff58 import DEFAULT_NODE_MAP, LOW_BAND_LIMIT_HZ, read_uff58, write_uff58

__all__ = ["write_uff58", "read_uff58", "DEFAULT_NODE_MAP", "LOW_BAND_LIMIT_HZ"]
