"""File formats (netCDF datasets, UFF58, CSV): readers and writers that import no stage.

Filled by the stages that produce files (impact campaigns onwards).
"""

__all__: list[str] = []
