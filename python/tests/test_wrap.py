"""Wrapping muscles: Python's wrap= is the CLI's --wrap (the same library setting), and the two
modes differ only where a wrap engages (issue 27)."""

import math
import re

import numpy as np
import pytest

import isowrench

from conftest import REPO

KNEE_WRAP = REPO / "tests" / "wrap" / "data" / "knee_wrap.urdf"
TOL = 1e-12
KNEES = [-2.0 + 0.25 * k for k in range(17)]  # rad, over the knee's range


def straight_copy(tmp_path):
    """The same leg with QUAD's path_wrap taken out: its straight path."""
    text = re.sub(r"\s*<isowrench:path_wrap[^>]*/>", "", KNEE_WRAP.read_text())
    path = tmp_path / "knee_straight.urdf"
    path.write_text(text)
    return path


def test_wrap_keyword_sets_the_model_mode():
    assert isowrench.load(str(KNEE_WRAP)).wrap == "opensim"
    exact = isowrench.load(str(KNEE_WRAP), wrap="exact")
    assert exact.wrap == "exact"
    assert exact.with_overrides(wrap="opensim").wrap == "opensim"
    assert isowrench.load(str(KNEE_WRAP)).with_overrides(wrap="exact").wrap == "exact"
    # Other overrides keep the mode.
    assert exact.with_overrides(base_stiffness=1e5).wrap == "exact"
    with pytest.raises(ValueError, match="shortest"):
        isowrench.load(str(KNEE_WRAP), wrap="shortest")


@pytest.mark.parametrize("mode", ["opensim", "exact"])
def test_wrap_keyword_equals_cli(cli, mode):
    m = isowrench.load(str(KNEE_WRAP), wrap=mode)
    for knee in KNEES[::4]:
        j = cli("kinematics", KNEE_WRAP, "--json", "--wrap", mode, "--posture",
                "hip=20,knee={}".format(math.degrees(knee)))
        p = j["postures"][0]
        k = m.kinematics({"hip": math.radians(20), "knee": knee})
        for name, entry in p["muscles"].items():
            assert abs(k["muscles"][name]["length_m"] - entry["length_m"]) <= TOL
            np.testing.assert_allclose(k["muscles"][name]["moment_arm_m"], entry["moment_arm_m"],
                                       rtol=0, atol=TOL)


def test_modes_differ_only_where_the_wrap_engages(cli, tmp_path):
    straight = straight_copy(tmp_path)
    engaged = differing = 0
    for knee in KNEES:
        posture = "hip=20,knee={}".format(math.degrees(knee))
        runs = {name: cli("kinematics", path, "--json", *extra, "--posture", posture)
                ["postures"][0]["muscles"]
                for name, path, extra in [("opensim", KNEE_WRAP, []),
                                          ("exact", KNEE_WRAP, ["--wrap", "exact"]),
                                          ("straight", straight, [])]}
        # The muscle without a wrap is the same in both modes, to the bit.
        assert runs["opensim"]["STRAIGHT"] == runs["exact"]["STRAIGHT"]
        wraps = runs["opensim"]["QUAD"]["length_m"] > runs["straight"]["QUAD"]["length_m"] + 1e-12
        same = runs["opensim"]["QUAD"] == runs["exact"]["QUAD"]
        if not wraps:
            # Not engaged: both modes give the straight path.
            assert same, knee
            # (the straight muscle's kernel and the wrapping one's sum in another order)
            assert abs(runs["opensim"]["QUAD"]["length_m"] -
                       runs["straight"]["QUAD"]["length_m"]) <= TOL, knee
            np.testing.assert_allclose(runs["opensim"]["QUAD"]["moment_arm_m"],
                                       runs["straight"]["QUAD"]["moment_arm_m"], rtol=0, atol=TOL)
        engaged += wraps
        differing += not same
        if wraps:
            # Engaged with the ends at different heights along the axis: OpenSim's cylinder path
            # is not the shortest one, so the exact length is below OpenSim's (and above straight).
            assert runs["exact"]["QUAD"]["length_m"] < runs["opensim"]["QUAD"]["length_m"], knee
            assert runs["exact"]["QUAD"]["length_m"] > runs["straight"]["QUAD"]["length_m"], knee
    assert engaged >= 4 and differing == engaged, (engaged, differing)
