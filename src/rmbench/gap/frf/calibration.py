"""The first calibration of a calibrated diagnosis: the nominal robot's ordinary parameters fitted
on the training postures before the structural search (:func:`first_calibration`), and the record
the search and the confirmation read (:class:`FirstCalibration`)."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from rmbench.gap.frf.prepare import SearchData

__all__ = ["FirstCalibration", "first_calibration"]


@dataclass(frozen=True)
class FirstCalibration:
    """The first calibration and what the diagnosis reads of it.

    Attributes
    ----------
    robot : Robot
        The calibrated robot (the structural search runs on it).
    account : dict
        :meth:`rmbench.calibrate.Calibration.to_json` with the ``groups`` calibrated.
    ordinary : Ordinary
        Its parameters linearised at every posture (:class:`~rmbench.gap.frf.joint.Ordinary`),
        for the joint search.
    cal : Calibration
        The calibration itself (the null recalibration's start).
    data : ModalData
        The modal data it was fitted to, training postures first, then the held-out ones.
    settings : CalibrationSettings
    """

    robot: object
    account: dict
    ordinary: object
    cal: object
    data: object
    settings: object


def first_calibration(problem: SearchData, settings, workers, say) -> FirstCalibration:
    """The nominal robot of ``problem`` calibrated on its training postures (scored on the
    held-out ones) for ``settings.calibrate``'s parameter groups; ``workers``: the calibration's
    worker processes, ``say``: the progress callback."""
    from rmbench.calibrate import CalibrationSettings, calibrate, linearisation
    from rmbench.gap.frf.joint import Ordinary
    from rmbench.robot import Robot

    robot, train, held = problem.robot, problem.train, problem.held
    order = list(train) + list(held)
    sub = problem.modal.subset(order)
    cal_settings = CalibrationSettings(groups=tuple(settings.calibrate), workers=workers)
    held_sub = list(range(len(train), len(order)))
    cal = calibrate(robot, sub, held=held_sub, settings=cal_settings, progress=say)
    if cal.at_limit:
        # a fit still moving at its limit: the search would start from a model the ordinary
        # parameters have not finished with, and blame the rest of the way on a structural effect
        say(f"the calibration stopped at its limit of {cal_settings.max_iter} evaluations: continued "
            "from where it stopped")
        more = calibrate(robot, sub, held=held_sub, settings=cal_settings, progress=say,
                         start=dict(zip([p.name for p in cal.params], np.asarray(cal.u, float))))
        cal = replace(more, iterations=cal.iterations + more.iterations,
                      seconds=round(cal.seconds + more.seconds, 3))
    fitted = Robot(cal.xml, name=robot.name, tool=robot.tool, spindle_rpm=robot.spindle_rpm)
    account = cal.to_json()
    account["groups"] = list(settings.calibrate)
    blocks, z, names = linearisation(robot, sub, cal.u, range(len(order)), cal_settings)
    ordinary = Ordinary({(order[i], b): J for (i, b), (_, J) in blocks.items()}, z, names)
    say("calibrated parameters linearised for the joint search")
    return FirstCalibration(fitted, account, ordinary, cal, sub, cal_settings)
