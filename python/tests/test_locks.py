"""Locked coordinates (issue 25): Python's locked= means what the CLI's --lock means, and a
posture without equilibrium is never a number (NaN and a warning, not zeros)."""

import numpy as np
import pytest

import isowrench

from conftest import URDF

TOL = 1e-12  # the CLI prints JSON with 17 significant digits; both run the same C++


def wrench_vector(j):
    return np.array([j[k] for k in ("fx", "fy", "fz", "mx", "my", "mz")])


@pytest.fixture(scope="module")
def rat6():
    return isowrench.load(str(URDF / "rat_hindlimb_6dof.urdf"))


def test_locked_argument_equals_cli_lock(cli, rat6):
    path = URDF / "rat_hindlimb_6dof.urdf"
    j = cli("wrench", path, "--json", "--lock", "knee_rx")
    w = rat6.wrench("GP", locked=["knee_rx"])
    assert w.locked == ["knee_rx"] == j["locked"]
    assert [joint["locked"] for joint in j["joints"]] == [c == "knee_rx" for c in w.coordinates]
    np.testing.assert_allclose(w.transducer, wrench_vector(j["wrench"]), rtol=0, atol=TOL)
    np.testing.assert_allclose(w.dtheta, [joint["dtheta"] for joint in j["joints"]], rtol=0, atol=TOL)
    assert w.dtheta[w.coordinates.index("knee_rx")] == 0.0  # rigid
    # The lock changes the answer (the knee's axial rotation no longer gives).
    assert np.abs(rat6.wrench("GP").transducer - w.transducer).max() > 1e-6
    # A string means the same as a list; [] unlocks everything.
    np.testing.assert_array_equal(rat6.wrench("GP", locked="knee_rx").transducer, w.transducer)
    np.testing.assert_array_equal(rat6.wrench("GP", locked=[]).transducer, rat6.wrench("GP").transducer)

    d = cli("diagnose", path, "--json", "--lock", "knee_rx", "--no-large-deflection")["postures"][0]
    mine = rat6.diagnose("GP", locked=["knee_rx"], large_deflection=False)
    assert mine["constraints"]["class"] == d["constraints"]["class"] == "over-constrained"
    assert mine["constraints"]["joint_dofs"] == d["constraints"]["joint_dofs"] == 5
    assert mine["constraints"]["locked"] == d["constraints"]["locked"] == ["knee_rx"]
    np.testing.assert_allclose(mine["constraints"]["singular_values"], d["constraints"]["singular_values"],
                               rtol=0, atol=TOL)
    assert mine["compliance_verdict"] == d["muscles"][0]["compliance_verdict"]

    r = cli("releases", path, "--json", "--lock", "knee_rx")["postures"][0]["muscles"][0]
    mine = rat6.releases("GP", locked=["knee_rx"])
    assert [c["verdict"] for c in mine["candidates"]] == [c["verdict"] for c in r["candidates"]]
    assert mine["recommendation"] == r["recommendation"]
    with pytest.raises(ValueError, match="kne_rx"):
        rat6.wrench("GP", locked=["kne_rx"])


def test_model_lists_its_locks():
    m = isowrench.load(str(URDF.parent / "tests" / "data" / "rat_hindlimb_6dof_locked.urdf"))
    assert m.locked == ["knee_rx"]
    assert m.wrench("GP").locked == ["knee_rx"]
    assert isowrench.load(str(URDF / "rat_hindlimb_6dof.urdf")).locked == []


def test_no_equilibrium_is_nan_with_a_warning(rat):
    # Released x and y: GP drives the in-plane hip-knee self-motion, no equilibrium.
    Q = np.tile(rat.default_posture, (3, 1))
    Q[1, 3] += 0.1
    with pytest.warns(RuntimeWarning, match="3 of 3 postures of 'GP' have no equilibrium"):
        W, status = rat.wrench_batch("GP", Q, released=["x", "y"], return_status=True)
    assert np.isnan(W).all()
    assert all(isowrench.STATUS_NAMES[s] == "self-motion" for s in status)
    w = rat.wrench("GP", released=["x", "y"])
    assert not w.equilibrium and w.status == "self-motion"
    assert np.isnan(w.transducer).all() and np.isnan(w.world).all() and np.isnan(w.dtheta).all()
    assert "no equilibrium" in repr(w)
    d = rat.diagnose("GP", released=["x", "y"], large_deflection=False)
    assert d["wrench"] is None and d["equilibrium"] is False
    # With an equilibrium: numbers and no warning.
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        W = rat.wrench_batch("GP", Q)
    assert np.isfinite(W).all()


def test_lock_errors_name_the_keyword_as_the_cli(rat6):
    # The CLI says "--lock: unknown coordinate 'nope'"; Python names its keyword the same way.
    with pytest.raises(ValueError, match=r"^locked: unknown coordinate 'nope'"):
        rat6.wrench("GP", locked=["nope"])
    with pytest.raises(ValueError, match=r"^locked: 'none' together with 'knee_rx'"):
        rat6.with_overrides(locked=["none", "knee_rx"])
    with pytest.raises(ValueError, match=r"^locked: an empty string"):
        rat6.wrench("GP", locked="")
    # base_stiffness first, then the lock, as the CLI: the lock can name the base dofs.
    m = rat6.with_overrides(base_stiffness=1e5, locked=["base_z", "knee_rx"])
    assert m.locked == ["base_z", "knee_rx"]


def test_uncertainty_checks_the_statics_keywords(rat6):
    with pytest.raises(ValueError, match=r"max_joint_rotation nan: must be a finite number > 0"):
        rat6.uncertainty("GP", inputs=["max_force=normal:0.1"], samples=64,
                         max_joint_rotation=float("nan"))
    # A tighter small-motion rule reaches the study (the CLI's --max-joint-rotation).
    loose = rat6.uncertainty("GP", inputs=["max_force=normal:0.1"], samples=64)
    tight = rat6.uncertainty("GP", inputs=["max_force=normal:0.1"], samples=64,
                             max_joint_rotation=1e-12)
    [p_loose], [p_tight] = loose["postures"], tight["postures"]
    assert p_loose["counts"]["small_motion_failed"] == 0
    assert p_tight["counts"]["small_motion_failed"] == p_tight["counts"]["valid"] > 0
