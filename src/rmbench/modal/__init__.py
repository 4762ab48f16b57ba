"""Modal fitting of measured FRF matrices (METHODS §2): pLSCF, stabilisation, MDOF fit.

::

    fit = ModalFit().fit(freq, H, coherence)   # one band of one posture, 4x4 receptance
    fit.f_n_, fit.zeta_, fit.phi_r_, fit.phi_l_, fit.params_, fit.std_
    fit.fit_ok_, fit.fit_reason_, fit.quality_ # the verdict: a failed fit says so
    fit.predict(freq)                          # model FRF incl. residual terms
    synthesize(freq, poles, phi_r, phi_l)      # Eq. 15
    table_b1("high"), random_system(rng)       # known systems to test a fitter on
"""

from rmbench.modal.fit import PARAM_NAMES, ModalFit, ModalFitWarning, NotFittedError
from rmbench.modal.mdof import lsfd, synthesize
from rmbench.modal.plscf import PolyMaxOrder, plscf
from rmbench.modal.quality import FitQuality, ModeEvidence, QualityCriteria
from rmbench.modal.stabilization import StabilityCriteria, Stabilization, stabilize
from rmbench.modal.synthetic import (FitScore, MdofSystem, add_noise, random_system, score_fit,
                                     table_b1)

__all__ = ["ModalFit", "ModalFitWarning", "NotFittedError", "PARAM_NAMES", "synthesize", "lsfd",
           "plscf", "PolyMaxOrder", "stabilize", "Stabilization", "StabilityCriteria",
           "QualityCriteria", "FitQuality", "ModeEvidence", "MdofSystem", "FitScore", "table_b1",
           "random_system", "add_noise", "score_fit"]
