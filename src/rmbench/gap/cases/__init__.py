"""Cases the diagnoses are checked on, apart from the product code: blind FRF cases with a hidden
effect (:mod:`.blind`), those effects drawn and injected (:mod:`.hidden`) by plain MJCF edits
(:mod:`.truth`), blind tracker cases (:mod:`.tracker_blind`), and the one real robot held, seed
000's IRB6660 (:mod:`.real`). Nothing in :mod:`rmbench.gap.frf` or :mod:`rmbench.gap.tracker`
imports them.
"""
