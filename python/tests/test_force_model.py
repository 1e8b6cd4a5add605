"""The force stage in Python (docs/muscle.md "In the engine"): the same numbers as the CLI's
JSON, --force-model as force_model=, the passive wrench, and the imported rat models (skipped
when RatHindlimb is absent: it is never part of the repository)."""

import os
import pathlib
import subprocess

import numpy as np
import pytest

import isowrench

from conftest import REPO, cli_path

LIMB = REPO / "tests" / "data" / "force_model_limb.urdf"
MUSCLES = ["GP_compliant", "GP_rigid", "GP_thelen", "GP_no_opensim", "GP_constant"]
RAT = pathlib.Path("/work/ext/RatHindlimb/models/osim")
FORCE_KEYS = ["force_n", "active_force_n", "passive_force_n", "fiber_length_m", "pennation_rad",
              "tendon_strain", "activation_used"]


def close(a, b, tol=1e-12):
    return abs(a - b) <= tol * max(1.0, abs(a), abs(b))


def test_wrench_json_and_python_agree(cli):
    m = isowrench.load(str(LIMB))
    for name in MUSCLES:
        j = cli("wrench", LIMB, "--muscle", name, "--activation", "0.6", "--json")
        w = m.wrench(name, activation=0.6)
        assert j["muscle"]["force_model"]["model"] == w.force["model"]
        assert j["muscle"]["force_model"]["status"] == w.force["status"]
        for key in FORCE_KEYS:
            assert close(j["muscle"]["force_model"][key], w.force[key]), (name, key)
            assert close(j["muscle"]["passive_force_model"][key], w.passive_force[key])
        cli_w = [j["wrench"][k] for k in ("fx", "fy", "fz", "mx", "my", "mz")]
        np.testing.assert_allclose(w.transducer, cli_w, rtol=1e-12, atol=1e-15)
        cli_p = [j["passive_wrench"]["wrench"][k] for k in ("fx", "fy", "fz", "mx", "my", "mz")]
        np.testing.assert_allclose(w.passive, cli_p, rtol=1e-12, atol=1e-15)
        assert j["muscle"]["force_model"]["opensim_gives_no_number"] == (name == "GP_no_opensim")


def test_kinematics_json_and_python_agree(cli):
    m = isowrench.load(str(LIMB))
    j = cli("kinematics", LIMB, "--activation", "0.3", "--json")
    k = m.kinematics(activation=0.3)
    for name in MUSCLES:
        for key in FORCE_KEYS:
            assert close(j["postures"][0]["muscles"][name]["force"][key],
                         k["muscles"][name]["force"][key]), (name, key)


def test_passive_wrench_is_the_wrench_at_activation_zero():
    m = isowrench.load(str(LIMB))
    for name in MUSCLES:
        w = m.wrench(name, activation=0.8)
        zero = m.wrench(name, activation=0.0)
        np.testing.assert_allclose(w.passive, zero.transducer, rtol=1e-12, atol=1e-15)
    assert np.all(m.wrench("GP_constant").passive == 0.0)


def test_force_model_override_reproduces_the_constant_numbers(cli):
    m = isowrench.load(str(LIMB))
    constant = m.with_overrides(force_model="constant")
    also = isowrench.load(str(LIMB), force_model="constant")
    reference = m.wrench("GP_constant", activation=0.7).transducer
    for name in MUSCLES:
        assert np.array_equal(constant.wrench(name, activation=0.7).transducer, reference)
        assert np.array_equal(also.wrench(name, activation=0.7).transducer, reference)
        j = cli("wrench", LIMB, "--muscle", name, "--activation", "0.7", "--force-model",
                "constant", "--json")
        assert j["muscle"]["force_model"]["model"] == "constant"
        assert j["muscle"]["force_N"] == 0.7 * 2.35
    rigid = m.with_overrides(force_model="rigid")
    assert rigid.wrench("GP_compliant").force["tendon"] == "rigid"
    with pytest.raises(ValueError, match="force_model 'hill'"):
        m.with_overrides(force_model="hill")


def test_activation_outside_zero_one_is_an_error():
    m = isowrench.load(str(LIMB))
    with pytest.raises(ValueError, match="1.5"):
        m.wrench("GP_compliant", activation=1.5)
    with pytest.raises(ValueError, match="-0.1"):
        m.wrench_batch("GP_thelen", np.tile(m.default_posture, (3, 1)), activation=-0.1)


@pytest.mark.parametrize("model", ["rat_hindlimb_unilateral.osim", "rat_hindlimb.osim"])
def test_rat_models_print_every_muscles_force(model, tmp_path):
    path = RAT / model
    if not path.exists():
        pytest.skip(f"{path} is absent (RatHindlimb is not shipped)")
    with pytest.warns(UserWarning):
        m = isowrench.load(str(path), clamp_body="pelvis_r", endpoint_body="foot_r")
    forces = m.kinematics()["muscles"]
    assert len(forces) == 38
    for name, entry in forces.items():
        f = entry["force"]
        assert f["model"] in ("millard2012", "thelen2003"), name
        assert np.isfinite(f["force_n"]) and f["force_n"] >= 0.0, name
        if model == "rat_hindlimb.osim":  # Thelen2003, tendon_slack_length 0
            assert f["opensim_gives_no_number"] and "rigid-tendon limit" in f["opensim_note"]
    # The CLI on the imported URDF (in tmp_path, never in the repository) prints them all.
    exe = cli_path()
    if not exe:
        pytest.skip("the isowrench CLI is not built")
    urdf = tmp_path / "rat.urdf"
    subprocess.run([exe, "import", str(path), "--clamp", "pelvis_r", "--endpoint", "foot_r",
                    "-o", str(urdf)], check=True, capture_output=True)
    out = subprocess.run([exe, "kinematics", str(urdf)], check=True, capture_output=True,
                         text=True).stdout
    for name in forces:
        assert f"  {name} [" in out and "F " in out, name
    if model == "rat_hindlimb.osim":
        assert out.count("OpenSim gives no number for this muscle") == 38
