"""isowrench: the wrench a stimulated muscle applies through a compliantly restrained limb to a
6-axis force/torque transducer (paper Eq. 10), from Python.

    import isowrench, numpy as np
    m = isowrench.load("urdf/rat_hindlimb_5dof.urdf")
    m.coordinates, m.muscles, m.default_posture      # names; numpy array (rad / m)
    k = m.kinematics()                               # endpoint_m, jacobian (6, n), muscles
    w = m.wrench("GP")                               # w.transducer, w.world: (6,) N and N m
    W = m.wrench_batch("GP", Q)                      # Q (N, n) -> (N, 6), GIL released
    isowrench.simulate(m, "data.csv", effects=["base_isotropic=2e5"])
    isowrench.fit(m, "data.csv")["verdict"]

Angles are radians and lengths metres everywhere (the CLI's degrees and mm stay on the command
line). Bad input raises ValueError with the C++ message; a missing file FileNotFoundError.
See docs/python.md.
"""

from ._core import STATUS_NAMES, Model, Wrench, __version__, fit, load, simulate

__all__ = ["Model", "STATUS_NAMES", "Wrench", "__version__", "fit", "load", "simulate"]
