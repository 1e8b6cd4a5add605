"""The module gives the CLI's --json numbers (same library underneath) to 1e-12."""

import math

import numpy as np
import pytest

import isowrench

from conftest import URDF

TOL = 1e-12
MODELS = ["rat_hindlimb_5dof.urdf", "rat_hindlimb_6dof.urdf", "rat_hindlimb_5dof_base.urdf",
          "rat_hindlimb_coupled_knee.urdf", "planar_2r.urdf", "planar_4r.urdf"]


def wrench_vector(j):
    return np.array([j[k] for k in ("fx", "fy", "fz", "mx", "my", "mz")])


@pytest.mark.parametrize("name", MODELS)
def test_kinematics_equals_cli_json(cli, name):
    path = URDF / name
    m = isowrench.load(str(path))
    j = cli("kinematics", path, "--json")
    assert m.coordinates == j["coordinates"]
    p = j["postures"][0]
    k = m.kinematics()
    np.testing.assert_allclose(k["endpoint_m"], p["endpoint_m"], rtol=0, atol=TOL)
    np.testing.assert_allclose(k["jacobian"], np.array(p["jacobian"]), rtol=0, atol=TOL)
    assert list(k["muscles"]) == list(p["muscles"])
    for muscle, entry in p["muscles"].items():
        assert abs(k["muscles"][muscle]["length_m"] - entry["length_m"]) <= TOL
        np.testing.assert_allclose(k["muscles"][muscle]["moment_arm_m"], entry["moment_arm_m"], rtol=0, atol=TOL)


# base_x=20 (mm) is beyond the base's +-10 mm limits: the warning is expected.
@pytest.mark.filterwarnings("ignore:.*outside the joint's limits:UserWarning")
@pytest.mark.parametrize("name", MODELS)
@pytest.mark.parametrize("options", [[], ["--transducer", "ati-mini40", "--release", "rz"],
                                     ["--transducer-stiffness", "1e6,2e6,3e6,40,50,60", "--release", "none"]])
def test_wrench_equals_cli_json(cli, name, options):
    path = URDF / name
    m = isowrench.load(str(path))
    muscle = m.muscles[-1]
    posture = "{}=20".format(m.coordinates[0])
    j = cli("wrench", path, "--json", "--muscle", muscle, "--posture", posture, *options)
    q = np.array([joint["q"] for joint in j["joints"]])  # rad / m as the CLI evaluated them
    assert abs(q[0] - math.radians(20)) <= 1e-15 or m.coordinate_types[0] == "prismatic"
    transducer = released = None
    if options:
        transducer = options[1] if options[0] == "--transducer" else [float(v) for v in options[1].split(",")]
        released = [] if options[3] == "none" else options[3].split(",")
    w = m.wrench(muscle, q, transducer=transducer, released=released)
    assert w.status == j["statics"]["status"]
    assert abs(w.muscle_length_m - j["muscle"]["length_m"]) <= TOL
    assert w.muscle_force_N == j["muscle"]["force_N"]
    np.testing.assert_allclose(w.tau, [joint["tau"] for joint in j["joints"]], rtol=0, atol=TOL)
    if j["equilibrium"]:
        np.testing.assert_allclose(w.transducer, wrench_vector(j["wrench"]), rtol=0, atol=TOL)
        np.testing.assert_allclose(w.world, wrench_vector(j["wrench_world"]), rtol=0, atol=TOL)
        np.testing.assert_allclose(w.dtheta, [joint["dtheta"] for joint in j["joints"]], rtol=0, atol=TOL)
        assert w.small_motion == j["small_motion"]["valid"]
    if j["classic"]["method"] is not None:
        np.testing.assert_allclose(w.classic, wrench_vector(j["classic"]["wrench"]), rtol=0, atol=TOL)


def test_default_posture_is_the_urdf_nominal_posture(rat):
    # <isowrench:posture joint="hip_rz" degrees="-110"/>, knee_rz 105 degrees, others 0.
    np.testing.assert_allclose(rat.default_posture, np.radians([-110, 0, 0, 105, 0]), rtol=0, atol=1e-15)
    assert rat.coordinates == ["hip_rz", "hip_ry", "hip_rx", "knee_rz", "knee_rx"]
    assert rat.muscles == ["GP"]


def test_posture_dict_equals_array(rat):
    q = rat.default_posture.copy()
    q[1] = 0.3
    a = rat.wrench("GP", q)
    b = rat.wrench("GP", {"hip_ry": 0.3})
    np.testing.assert_array_equal(a.transducer, b.transducer)


def test_releases_and_diagnose_equal_cli_json(cli, rat):
    path = URDF / "rat_hindlimb_5dof.urdf"
    j = cli("releases", path, "--json", "--muscle", "GP")["postures"][0]["muscles"][0]
    r = rat.releases("GP")
    assert r["recommended"] == j["recommended"]
    assert r["recommendation"] == j["recommendation"]
    assert [c["name"] for c in r["candidates"]] == [c["name"] for c in j["candidates"]]
    for mine, theirs in zip(r["candidates"] + [r["baseline"]], j["candidates"] + [j["baseline"]]):
        assert mine["verdict"] == theirs["verdict"]
        assert abs(mine["margin"] - theirs["margin"]) <= TOL
        # No equilibrium (a forbidden release): no wrench in either, never zeros.
        assert (mine["wrench"] is None) == (theirs["wrench"] is None) == (not theirs["equilibrium"])
        if mine["wrench"] is not None:
            np.testing.assert_allclose(wrench_vector(mine["wrench"]), wrench_vector(theirs["wrench"]),
                                       rtol=0, atol=TOL)
    d = cli("diagnose", path, "--json", "--muscle", "GP")["postures"][0]
    mine = rat.diagnose("GP")
    assert mine["constraints"]["class"] == d["constraints"]["class"]
    np.testing.assert_allclose(mine["constraints"]["singular_values"], d["constraints"]["singular_values"],
                               rtol=0, atol=TOL)
    theirs = d["muscles"][0]
    np.testing.assert_allclose(wrench_vector(mine["wrench"]), wrench_vector(theirs["wrench"]), rtol=0, atol=TOL)
    assert [e["parameter"] for e in mine["sensitivity"]["entries"]] == \
        [e["parameter"] for e in theirs["sensitivity"]["entries"]]


def rotation_rpy(r, p, y):
    """URDF rpy: R = Rz(y) Ry(p) Rx(r)."""
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    return rz @ ry @ rx


@pytest.mark.parametrize("axes", ["world", "link"])
def test_rotated_transducer_world_wrench(cli, tmp_path, axes):
    """World-axes wrench = R_W_T times the transducer-axes wrench, in Python and the CLI's JSON;
    with a balanced transducer it equals the aligned transducer's (W = pinv(J^T) tau)."""
    text = (URDF / "rat_hindlimb_5dof.urdf").read_text()
    aligned = 'rpy="0 0 0" axes="world"'
    assert aligned in text
    path = tmp_path / "rotated.urdf"
    path.write_text(text.replace(aligned, 'rpy="0.4 0.5 -0.3" axes="{}"'.format(axes)))
    reference = isowrench.load(str(URDF / "rat_hindlimb_5dof.urdf")).wrench("GP")
    m = isowrench.load(str(path))
    w = m.wrench("GP")
    r = rotation_rpy(0.4, 0.5, -0.3)
    if axes == "link":  # the tibia's rotation at the nominal posture: hip_rz + knee_rz about z
        r = rotation_rpy(0, 0, math.radians(-110 + 105)) @ r
    expected = np.concatenate([r @ w.transducer[:3], r @ w.transducer[3:]])
    scale = np.linalg.norm(reference.world)
    np.testing.assert_allclose(w.world, expected, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(w.world, reference.world, rtol=0, atol=1e-9 * scale)
    assert np.linalg.norm(w.transducer - reference.transducer) > 0.05 * scale
    j = cli("wrench", path, "--json", "--muscle", "GP")
    np.testing.assert_allclose(wrench_vector(j["wrench_world"]), expected, rtol=0, atol=1e-12 * scale)
