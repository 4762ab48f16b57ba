"""Machining along a tool path with posture-dependent dynamics.

The chain each posture of a path needs, seed 000's whole method composed from the stages below
it: predicted reference-tool dynamics (:mod:`rmbench.predict`) → the target tool put on by RCSA
(:mod:`rmbench.rcsa`) → its modes fitted (:mod:`rmbench.modal`) → stability lobes
(:mod:`rmbench.stability`)::

    from rmbench.path import predicted_lobes
    res = predicted_lobes(prediction, bands, reference_tool, target_tool, cutting, speeds, depths)
"""

from rmbench.path.chain import ChainResult, predicted_lobes, predicted_tool_structures, tool_structures

__all__ = ["ChainResult", "tool_structures", "predicted_tool_structures", "predicted_lobes"]
