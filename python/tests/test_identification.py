"""isowrench.simulate and isowrench.fit: the CLI's simulate file, and a planted effect recovered."""

import numpy as np
import pytest

import isowrench

from conftest import REPO, URDF


def test_simulate_defaults_are_the_clis(cli, rat, tmp_path):
    # One set of defaults (SimulationOptions{}): 50 trials, seed 1, in Python and on the command line.
    ours = isowrench.simulate(rat, str(tmp_path / "py.csv"))
    summary = cli("simulate", URDF / "rat_hindlimb_5dof.urdf", "-o", tmp_path / "cli.csv", "--json")
    assert summary["trials"] == 50 and summary["seed"] == 1
    assert open(ours).read() == (tmp_path / "cli.csv").read_text()


def test_simulate_writes_the_cli_file(cli, rat, tmp_path):
    ours = isowrench.simulate(rat, str(tmp_path / "py.csv"), effects=["base_isotropic=2e5"], trials=40, seed=3)
    cli("simulate", URDF / "rat_hindlimb_5dof.urdf", "--effect", "base_isotropic=2e5", "--trials", 40,
        "--seed", 3, "-o", tmp_path / "cli.csv", "--json")
    assert open(ours).read() == (tmp_path / "cli.csv").read_text()


def test_fit_recovers_a_planted_base_stiffness(rat, tmp_path):
    path = isowrench.simulate(rat, str(tmp_path / "data.csv"), effects=["base_isotropic=2e5"], trials=60, seed=7)
    fit = isowrench.fit(rat, path)
    assert fit["verdict"] == "explained"
    assert fit["trial_count"] == 60
    assert [c["id"] for c in fit["chosen"]] == ["base_isotropic"]
    k = fit["chosen"][0]["parameters"][0]
    assert k["name"] == "k_base" and k["unit"] == "N/m"
    assert 0 < k["standard_error"] < 0.05 * 2e5
    assert abs(k["value"] - 2e5) < 4 * k["standard_error"]
    # Data noise is 0.002 N / 5e-5 N·m per component: after the fit the residual is at that level.
    np.testing.assert_array_less(fit["rms_after"], [0.004] * 3 + [1e-4] * 3)
    assert np.all(fit["rms_before"] > 10 * fit["rms_after"])


def test_fit_errors(rat, tmp_path):
    with pytest.raises(FileNotFoundError):
        isowrench.fit(rat, str(tmp_path / "missing.csv"))
    bad = tmp_path / "bad.csv"
    bad.write_text("muscle,activation,hip_rz,fx\nGP,1,0,nan\n")
    with pytest.raises(ValueError, match="bad.csv"):
        isowrench.fit(rat, str(bad))
    with pytest.raises(ValueError, match="no_such_effect"):
        isowrench.simulate(rat, str(tmp_path / "x.csv"), effects=["no_such_effect=1"])


def test_fit_a_sample_of_the_rows(rat, tmp_path):
    path = isowrench.simulate(rat, str(tmp_path / "data.csv"), effects=["base_isotropic=2e5"], trials=120, seed=7)
    fit = isowrench.fit(rat, path, max_fit_trials=40, sample_seed=3)
    assert fit["trial_count"] == 120 and fit["fitted_trial_count"] == 40
    assert "40 of 120 trials fitted" in fit["sampling"] and "seed 3" in fit["sampling"]
    assert [c["id"] for c in fit["chosen"]] == ["base_isotropic"]
    # rms_after covers all 120 rows: at the noise, although only 40 were fitted.
    np.testing.assert_array_less(fit["rms_after"], [0.004] * 3 + [1e-4] * 3)
    every = isowrench.fit(rat, path, max_fit_trials=0)
    assert every["fitted_trial_count"] == 120 and every["sampling"] == "every trial fitted"
    with pytest.raises(ValueError, match="max_fit_trials"):
        isowrench.fit(rat, path, max_fit_trials=-1)


def test_simulate_at_a_posture_sheet_is_the_clis(cli, rat, tmp_path):
    # design -o writes a posture sheet; Python's simulate(postures=) and the CLI's
    # simulate --postures read it alike (one library function).
    cli("design", URDF / "rat_hindlimb_5dof.urdf", "--effects", "base_isotropic", "--n", 6,
        "--grid", 50, "-o", tmp_path / "d.csv", "--json")
    ours = isowrench.simulate(rat, str(tmp_path / "py.csv"), effects=["base_isotropic=3e6"],
                              postures=str(tmp_path / "d.csv"))
    cli("simulate", URDF / "rat_hindlimb_5dof.urdf", "--postures", tmp_path / "d.csv",
        "--effect", "base_isotropic=3e6", "-o", tmp_path / "cli.csv", "--json")
    text = open(ours).read()
    assert text == (tmp_path / "cli.csv").read_text()
    assert len([l for l in text.splitlines() if l[:1] in "-0123456789"]) == 6


def test_fit_reads_lab_sheets_as_the_cli(rat, tmp_path):
    # The CLI's --delimiter / --decimal-comma / --ignore-columns / --skip-rows as keywords: a
    # spreadsheet export (';' and decimal commas, a trial id column, a preamble) gives the
    # plain file's fit.
    plain = isowrench.simulate(rat, str(tmp_path / "plain.csv"), effects=["base_isotropic=3e6"],
                               trials=40, seed=9)
    lines = open(plain).read().splitlines()
    excel = ["ATI export", "# comment"] + [
        ("trial;" if i == 1 else "{};".format(i)) + l.replace(",", ";").replace(".", ",")
        for i, l in enumerate(lines) if not l.startswith("#")]
    (tmp_path / "excel.csv").write_text("\n".join(excel) + "\n")
    ours = isowrench.fit(rat, str(tmp_path / "excel.csv"), delimiter=";", decimal_comma=True,
                         ignore_columns=["trial"], skip_rows=1)
    reference = isowrench.fit(rat, plain)
    assert ours["verdict_message"] == reference["verdict_message"]
    np.testing.assert_array_equal(ours["rms_after"], reference["rms_after"])
    with pytest.raises(ValueError, match="uses ';' as the separator"):
        isowrench.fit(rat, str(tmp_path / "excel.csv"), skip_rows=1)
    with pytest.raises(ValueError, match="delimiter 'x' is not one of"):
        isowrench.fit(rat, plain, delimiter="x")


def test_fit_names_the_radians_slip(rat):
    # At load (a UserWarning) and in the verdict.
    with pytest.warns(UserWarning, match=r"trials_radians\.csv: the angles of hip_rz, .* recorded in radians\?"):
        fit = isowrench.fit(rat, str(REPO / "tests" / "data" / "trials_radians.csv"))
    assert "likely slip: the angles of hip_rz" in fit["verdict_message"]
    assert "recorded in radians?" in fit["verdict_message"]
