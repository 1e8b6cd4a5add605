"""Bad input becomes a Python exception with the C++ message, never a crash."""

import numpy as np
import pytest

import isowrench

from conftest import URDF


def test_missing_file_is_file_not_found(tmp_path):
    with pytest.raises(FileNotFoundError, match="no_such.urdf"):
        isowrench.load(str(tmp_path / "no_such.urdf"))


def test_bad_model_is_value_error_naming_file_and_line(tmp_path):
    bad = tmp_path / "bad.urdf"
    text = (URDF / "rat_hindlimb_5dof.urdf").read_text().replace('max_force="2.3"', 'max_force="-2.3"')
    bad.write_text(text)
    with pytest.raises(ValueError) as info:
        isowrench.load(str(bad))
    message = str(info.value)
    assert "bad.urdf" in message and "-2.3" in message
    line = next(i + 1 for i, l in enumerate(text.splitlines()) if 'max_force="-2.3"' in l)
    assert ":{}".format(line) in message


def test_malformed_xml_is_value_error(tmp_path):
    bad = tmp_path / "broken.urdf"
    bad.write_text("<robot name='x'>\n<link name='a'>\n</robot>\n")
    with pytest.raises(ValueError, match="broken.urdf"):
        isowrench.load(str(bad))


def test_unknown_muscle(rat):
    for call in (lambda: rat.wrench("XX"), lambda: rat.wrench_batch("XX", np.zeros((2, 5))),
                 lambda: rat.releases("XX"), lambda: rat.diagnose("XX")):
        with pytest.raises(ValueError, match="XX.*GP"):
            call()


def test_wrong_q_shapes(rat):
    with pytest.raises(ValueError, match=r"shape \(3, 4\).*\(N, 5\)"):
        rat.wrench_batch("GP", np.zeros((3, 4)))
    with pytest.raises(ValueError, match=r"shape \(5,\)"):
        rat.wrench_batch("GP", np.zeros(5))
    with pytest.raises(ValueError, match="5 values"):
        rat.wrench("GP", np.zeros(4))
    with pytest.raises(ValueError):
        rat.wrench_batch("GP", [["a"] * 5])


def test_nan_in_q_names_row_and_column(rat):
    Q = np.tile(rat.default_posture, (10, 1))
    Q[7, 3] = np.nan
    with pytest.raises(ValueError, match=r"Q\[7, 3\] \(knee_rz\) is nan"):
        rat.wrench_batch("GP", Q)
    q = rat.default_posture.copy()
    q[1] = np.inf
    with pytest.raises(ValueError, match="hip_ry"):
        rat.wrench("GP", q)
    with pytest.raises(ValueError, match="hip_ry"):
        rat.kinematics(q)


def test_unknown_coordinate_and_bad_options(rat):
    with pytest.raises(ValueError, match="knee_ry"):
        rat.wrench("GP", {"knee_ry": 0.1})
    with pytest.raises(ValueError, match="preset|stiffness"):
        rat.wrench("GP", transducer="nope")
    with pytest.raises(ValueError):
        rat.wrench("GP", transducer=[1, 2, 3])
    with pytest.raises(ValueError, match="qz"):
        rat.wrench("GP", released=["qz"])
    with pytest.raises(ValueError, match="threads"):
        rat.wrench_batch("GP", np.zeros((1, 5)), threads=-1)


def test_osim_needs_bodies(tmp_path):
    osim = tmp_path / "model.osim"
    osim.write_text("<OpenSimDocument Version='40000'/>")
    with pytest.raises(ValueError, match="clamp_body"):
        isowrench.load(str(osim))


# ---- issue 26: plausibility warnings are UserWarnings, never errors ---------------------------

def test_posture_in_degrees_warns_naming_the_coordinate(rat):
    import warnings as _w
    with pytest.warns(UserWarning, match=r"q\['hip_rz'\]: hip_rz = -6302\.54° \(-110 rad\) is more than a full turn \(degrees where radians were meant\?\)"):
        w = rat.wrench("GP", {"hip_rz": -110.0})
    assert w.status == "ok"  # a legal value: evaluated as given
    with _w.catch_warnings():
        _w.simplefilter("error")
        rat.wrench("GP", {"hip_rz": -1.9})  # plausible: no warning
        rat.wrench("GP")
    # An array in degrees: every implausible coordinate is named.
    with pytest.warns(UserWarning) as record:
        rat.kinematics([-110.0, 0.0, 0.0, 105.0, 0.0])
    texts = [str(r.message) for r in record]
    assert any("q['hip_rz']: hip_rz = -6302.54° (-110 rad)" in t for t in texts), texts
    assert any("q['knee_rz']: knee_rz = 6016.06° (105 rad)" in t for t in texts), texts


def test_batch_posture_in_degrees_warns_once_per_column(rat):
    Q = np.tile(rat.default_posture, (10, 1))
    Q[:, 3] = np.linspace(100, 110, 10)  # degrees in a radian column
    with pytest.warns(UserWarning, match=r"Q\[:, 3\]: knee_rz = 5729\.58° \(100 rad\) is more than a full turn") as record:
        rat.wrench_batch("GP", Q)
    assert len(record) == 1


def test_warnings_as_errors_raise_the_warning(rat):
    import warnings as _w
    with _w.catch_warnings():
        _w.simplefilter("error")
        with pytest.raises(UserWarning, match="more than a full turn"):
            rat.wrench("GP", {"hip_rz": -110.0})


def test_reader_warnings_become_user_warnings(tmp_path):
    text = (URDF / "rat_hindlimb_5dof.urdf").read_text()
    text = text.replace('rpy="0 0 0" axes="world"', 'rpy="0 0 90" axes="world"')
    path = tmp_path / "rpy_in_degrees.urdf"
    path.write_text(text)
    with pytest.warns(UserWarning, match=r"rpy_in_degrees\.urdf:37: <isowrench:transducer> rpy = 0 0 90 rad turns more than a full turn"):
        m = isowrench.load(str(path))
    assert m.name == "rat_hindlimb_5dof"


def test_overrides_are_the_clis(cli, rat):
    # The CLI's --base-stiffness / --joint-stiffness / --release / --transducer through the same
    # library function: the same wrench, and errors naming the Python keyword.
    m = rat.with_overrides(released=["rz"], transducer="ati-mini40", base_stiffness=2e5,
                           joint_stiffness={"knee_rx": 3.0})
    j = cli("wrench", URDF / "rat_hindlimb_5dof.urdf", "--json", "--release", "rz", "--transducer",
            "ati-mini40", "--base-stiffness", "2e5", "--joint-stiffness", "knee_rx=3")
    w = m.wrench("GP")
    np.testing.assert_allclose(w.transducer, [j["wrench"][k] for k in ("fx", "fy", "fz", "mx", "my", "mz")],
                               rtol=1e-12, atol=1e-15)
    assert m.released == ["rz"] and rat.released == []
    with pytest.raises(ValueError, match=r"base_stiffness: stiffness 1e\+308 exceeds the physical maximum"):
        rat.with_overrides(base_stiffness=1e308)
    with pytest.raises(ValueError, match=r"joint_stiffness knee_rx: stiffness -1 is negative"):
        rat.with_overrides(joint_stiffness={"knee_rx": -1.0})
