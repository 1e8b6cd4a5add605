"""The wrench of R_GS, R_VL and R_TA across the knee range with the muscles' own force models
(docs/muscle.md "In the engine"): total (activation 1), passive (activation 0: the pre-stimulus
baseline) and active (total - passive), on RatHindlimb's rat_hindlimb_unilateral.osim
(Millard2012EquilibriumMuscle). The model has no licence: it is read from where it lies and is
never copied into the repository; without it the script says so and exits 0.

usage: PYTHONPATH=build/python /usr/bin/python3 scripts/force_model_knee.py \
           [MODEL.osim] [OUTPUT.png]
"""

import os
import sys

import numpy as np

MODEL = "/work/ext/RatHindlimb/models/osim/rat_hindlimb_unilateral.osim"
OUTPUT = "docs/img/force_model_knee.png"
MUSCLES = ["R_GS", "R_VL", "R_TA"]
KNEE = "knee_r_flx"


def main(argv):
    model_path = argv[1] if len(argv) > 1 else MODEL
    output = argv[2] if len(argv) > 2 else OUTPUT
    if not os.path.exists(model_path):
        print(f"skipped: {model_path} is absent (RatHindlimb is not shipped with isowrench)")
        return 0
    import warnings

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    import isowrench

    warnings.simplefilter("ignore")  # the import's notes (length units) are not the point here
    m = isowrench.load(model_path, clamp_body="pelvis_r", endpoint_body="foot_r")
    knee = m.coordinates.index(KNEE)
    lower, upper = np.radians(-150.0), np.radians(-20.0)  # knee_r_flx's range in the model
    angles = np.linspace(lower, upper, 121)
    Q = np.tile(m.default_posture, (angles.size, 1))
    Q[:, knee] = angles
    deg = np.degrees(angles)

    fig, axes = plt.subplots(2, len(MUSCLES), figsize=(13, 7), sharex=True)
    for j, name in enumerate(MUSCLES):
        total = m.wrench_batch(name, Q, activation=1.0)
        passive = m.wrench_batch(name, Q, activation=0.0)
        active = total - passive
        force = np.array([m.kinematics(q)["muscles"][name]["force"] for q in Q], dtype=object)
        F = np.array([f["force_n"] for f in force])
        Fa = np.array([f["active_force_n"] for f in force])
        Fp = np.array([f["passive_force_n"] for f in force])
        F0 = np.array([m.kinematics(q, activation=0.0)["muscles"][name]["force"]["force_n"]
                       for q in Q])
        label = force[0]["label"]

        top = axes[0, j]
        top.plot(deg, F, "k", label="F, activation 1")
        top.plot(deg, Fa, "C0--", label="active part")
        top.plot(deg, Fp, "C3--", label="passive part")
        top.plot(deg, F0, "C2:", label="F, activation 0")
        top.set(title=f"{name}: {label}", ylabel="muscle force along the tendon (N)")
        top.legend(fontsize=8)

        bottom = axes[1, j]
        for values, style, what in [(total, "k", "total"), (active, "C0", "active"),
                                    (passive, "C3", "passive")]:
            bottom.plot(deg, np.linalg.norm(values[:, :3], axis=1), style, label=f"|f| {what}")
        bottom.set(xlabel=f"{KNEE} (deg)", ylabel="force on the transducer |f| (N)")
        bottom.legend(fontsize=8)
    fig.suptitle(f"{os.path.basename(model_path)}, other joints at the model's default posture: "
                 "Eq. 10 wrench force with the muscles' own force models\n"
                 "(total: activation 1; passive: activation 0, OpenSim's 1 % activation floor "
                 "included; active = total - passive)", fontsize=10)
    fig.tight_layout()
    os.makedirs(os.path.dirname(output) or ".", exist_ok=True)
    fig.savefig(output, dpi=100)
    print(f"wrote {output}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
