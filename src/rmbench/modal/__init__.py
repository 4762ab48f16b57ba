"""Modal fitting of measured FRF matrices (METHODS §2): pLSCF, stabilisation, MDOF fit.

::

    fit = ModalFit().fit(freq, H, coherence)   # one band of one posture, 4x4 receptance
    fit.f_n_, fit.zeta_, fit.phi_r_, fit.phi_l_, fit.params_, fit.std_
    fit.predict(freq)                          # model FRF incl. residual terms
    synthesize(freq, poles, phi_r, phi_l)      # Eq. 15
"""

from rmbench.modal.fit import PARAM_NAMES, ModalFit, ModalFitWarning, NotFittedError
from rmbench.modal.mdof import lsfd, synthesize
from rmbench.modal.plscf import PolyMaxOrder, plscf
from rmbench.modal.stabilization import StabilityCriteria, Stabilization, stabilize

__all__ = ["ModalFit", "ModalFitWarning", "NotFittedError", "PARAM_NAMES", "synthesize", "lsfd",
           "plscf", "PolyMaxOrder", "stabilize", "Stabilization", "StabilityCriteria"]
