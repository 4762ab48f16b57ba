"""rmbench: a virtual test bench for robotic machining dynamics.

Stages (one subpackage each, data flowing one way): ``robot`` (models, postures, exact ground
truth), ``impact``, ``modal``, ``predict``, ``rcsa``, ``stability``, ``tracker``, ``control``,
``gap``; ``io`` holds file formats and ``cli`` the command line.
"""

from rmbench._version import __version__
from rmbench.errors import RmbenchError

__all__ = ["__version__", "RmbenchError"]
