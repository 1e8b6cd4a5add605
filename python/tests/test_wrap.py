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


SPHERE_FAR_SIDE = REPO / "tests" / "wrap" / "data" / "sphere_far_side.urdf"


def assert_json_equal(a, b, where):
    """Equal keys; numbers within TOL, everything else equal."""
    if isinstance(b, dict):
        assert set(a) == set(b), (where, sorted(a), sorted(b))
        for key in b:
            assert_json_equal(a[key], b[key], where + [key])
    elif isinstance(b, (list, np.ndarray)):
        np.testing.assert_allclose(np.asarray(a, dtype=float), np.asarray(b, dtype=float),
                                   rtol=0, atol=TOL, err_msg=str(where))
    elif isinstance(b, float) and not isinstance(b, bool):
        assert abs(a - b) <= TOL, (where, a, b)
    else:
        assert a == b, (where, a, b)


@pytest.mark.parametrize("path,muscle,postures", [
    (KNEE_WRAP, "QUAD", ["hip=20,knee={}".format(math.degrees(k)) for k in KNEES[::3]]),
    # OpenSim's far-side sphere wrap (negative arc) at knee 0 and -40, behaving at -90 and 60.
    (SPHERE_FAR_SIDE, "FAR", ["knee=0", "knee=-40", "knee=-90", "knee=60"]),
])
@pytest.mark.parametrize("mode", ["opensim", "exact"])
def test_kinematics_wrap_modes_equal_cli(cli, path, muscle, postures, mode):
    """Model.kinematics() has kinematics --json's wrap_modes and wrap_warning, key for key; and
    the comparison's lengths are the two modes' engine lengths."""
    m = isowrench.load(str(path), wrap=mode)
    engines = {w: isowrench.load(str(path), wrap=w) for w in ("opensim", "exact")}
    misbehaving = 0
    for posture in postures:
        p = cli("kinematics", path, "--json", "--wrap", mode, "--posture", posture)["postures"][0]
        q = {name: math.radians(float(v)) for name, v in
             (item.split("=") for item in posture.split(","))}
        k = m.kinematics(q)
        assert_json_equal(k["wrap_modes"], p["wrap_modes"], [posture, "wrap_modes"])
        for name, entry in p["muscles"].items():
            assert k["muscles"][name].get("wrap_warning") == entry.get("wrap_warning"), posture
            assert_json_equal(k["muscles"][name]["force"] | {"label": None},
                              entry["force"] | {"label": None}, [posture, name, "force"])
        w = k["wrap_modes"][muscle]
        for other in ("opensim", "exact"):
            length = engines[other].kinematics(q, wrap_modes=False)["muscles"][muscle]["length_m"]
            assert abs(w["length_" + other + "_m"] - length) <= TOL, (posture, other)
        assert abs(w["length_difference_mm"] -
                   1e3 * (w["length_opensim_m"] - w["length_exact_m"])) <= 1e-9
        assert w["moment_arm_difference_coordinate"] in ("hip", "knee", None)
        misbehaving += w["opensim_misbehaves"] != ""
        # The warning of the model's mode at this posture is the muscle's wrap_warning.
        if mode == "opensim" and w["opensim_misbehaves"]:
            assert w["opensim_misbehaves"] in k["muscles"][muscle]["wrap_warning"]
    if path == SPHERE_FAR_SIDE:
        assert misbehaving == 2  # knee 0 and -40: the negative arc below the straight line
    assert "wrap_modes" not in m.kinematics(wrap_modes=False)
    assert "wrap_modes" not in isowrench.load(str(REPO / "urdf" / "planar_2r.urdf")).kinematics()


def test_wrap_mode_written_into_the_urdf_and_read_back(cli, tmp_path):
    """The wrap mode is part of the URDF (<robot isowrench:wrap_mode=...>): a model written in
    exact mode reads back in exact mode, and wrap= / --wrap still override it."""
    written = tmp_path / "far_exact.urdf"
    exact = isowrench.load(str(SPHERE_FAR_SIDE), wrap="exact")
    assert 'isowrench:wrap_mode="exact"' in exact.urdf_text
    written.write_text(exact.urdf_text)
    assert isowrench.load(str(written)).wrap == "exact"
    assert isowrench.load(str(written), wrap="opensim").wrap == "opensim"
    posture = "knee=0"  # OpenSim's far-side wrap; the exact path goes the long way round
    runs = {
        "file": cli("kinematics", written, "--json", "--posture", posture),
        "exact": cli("kinematics", SPHERE_FAR_SIDE, "--json", "--wrap", "exact", "--posture",
                     posture),
        "override": cli("kinematics", written, "--json", "--wrap", "opensim", "--posture",
                        posture),
        "opensim": cli("kinematics", SPHERE_FAR_SIDE, "--json", "--posture", posture),
    }
    far = {name: run["postures"][0]["muscles"]["FAR"] for name, run in runs.items()}
    assert far["file"] == far["exact"]
    assert far["override"] == far["opensim"]
    assert far["exact"]["length_m"] - far["opensim"]["length_m"] > 0.01
