"""isowrench.simulate and isowrench.fit: the CLI's simulate file, and a planted effect recovered."""

import re

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


def test_fit_takes_the_cli_options_and_writes_its_outputs(cli, rat, tmp_path):
    # The same options through Python and through `isowrench fit --json`: the same choices; the
    # URDF, HTML and markdown outputs are written; progress lines reach the callable.
    path = isowrench.simulate(rat, str(tmp_path / "data.csv"), effects=["force_scale:GP=0.9"], trials=40, seed=5)
    options = dict(rounds=2, folds=4, screen=3, loss="cauchy", loss_scale=2.5, threads=1,
                   candidates=["force_scale:GP", "sensor_offset", "base_isotropic", "gain:fx"])
    lines = []
    fit = isowrench.fit(rat, path, output=str(tmp_path / "aug.urdf"), report=str(tmp_path / "r.html"),
                        report_md=str(tmp_path / "r.md"), progress=lines.append, **options)
    ours = cli("fit", URDF / "rat_hindlimb_5dof.urdf", path, "--rounds", 2, "--folds", 4, "--screen", 3,
               "--loss", "cauchy", "--loss-scale", 2.5, "--threads", 1, "--candidates", ",".join(options["candidates"]),
               "--json")
    assert fit["verdict"] == ours["verdict"] == "explained"
    assert [c["id"] for c in fit["chosen"]] == [c["effect"] for c in ours["chosen"]] == ["force_scale:GP"]
    assert fit["chosen"][0]["parameters"][0]["value"] == pytest.approx(ours["chosen"][0]["parameters"][0]["value"], rel=1e-12)
    # Round tables: 4 candidates in round 1, 3 of them fitted (screen=3), k of each.
    first = fit["rounds"][0]
    assert first["chosen"] == "force_scale:GP"
    assert len(first["candidates"]) == 4
    assert sum(c["screened_out"] for c in first["candidates"]) == 1
    assert {c["id"]: c["k"] for c in first["candidates"]}["sensor_offset"] == 6
    # Outputs: the augmented URDF loads and holds the fitted force; the reports name the effect.
    augmented = (tmp_path / "aug.urdf").read_text()
    isowrench.load(str(tmp_path / "aug.urdf"))
    max_force = float(re.search(r'name="GP" max_force="([^"]+)"', augmented).group(1))
    assert max_force == pytest.approx(2.3 * fit["chosen"][0]["parameters"][0]["value"], rel=1e-6)
    assert "force_scale:GP" in (tmp_path / "r.html").read_text()
    assert "force_scale:GP" in (tmp_path / "r.md").read_text()
    # Progress: every stage, every candidate fit, in order.
    assert any(l.startswith("round 1: screening") for l in lines)
    assert any(l.startswith("round 1: fitted 3 of 3") for l in lines)
    assert any(l.startswith("round 1: cross-validated force_scale:GP") for l in lines)
    assert lines.index(next(l for l in lines if l.startswith("round 2"))) > lines.index(
        next(l for l in lines if l.startswith("round 1: fitted")))


def test_fit_option_errors(rat, tmp_path):
    path = isowrench.simulate(rat, str(tmp_path / "data.csv"), trials=20, seed=5)
    with pytest.raises(ValueError, match=r"max_rounds \(--rounds\) must be >= 0, got -1"):
        isowrench.fit(rat, path, rounds=-1)
    with pytest.raises(ValueError, match="--loss 'bogus'"):
        isowrench.fit(rat, path, loss="bogus")
    with pytest.raises(ValueError, match="no_such_effect"):
        isowrench.fit(rat, path, candidates=["no_such_effect"])
    with pytest.raises(TypeError, match="progress must be callable"):
        isowrench.fit(rat, path, progress=3)

    class Stop(Exception):
        pass

    def stop(line):
        raise Stop(line)

    with pytest.raises(Stop, match="round 1"):
        isowrench.fit(rat, path, rounds=1, progress=stop)


def test_fit_finds_a_planted_force_length_effect(tmp_path):
    # Issue 28 item 4: a muscle with a force model whose optimal fiber length is 15 % longer than
    # the model's: the fit names force_length:GP_compliant and l_o_scale comes back within 4 SE.
    limb = isowrench.load(str(REPO / "tests" / "data" / "force_model_limb.urdf"))
    path = isowrench.simulate(limb, str(tmp_path / "data.csv"),
                              effects=["force_length:GP_compliant=l_o_scale:1.15"],
                              muscles=["GP_compliant"], trials=60, seed=3)
    fit = isowrench.fit(limb, path, rounds=2,
                        candidates=["force_length:GP_compliant", "force_scale:GP_compliant",
                                    "joint_offset:knee_rz", "trial_force"])
    assert fit["verdict"] == "explained"
    assert [c["id"] for c in fit["chosen"]] == ["force_length:GP_compliant"]
    l_o = fit["chosen"][0]["parameters"][0]
    assert l_o["name"] == "l_o_scale" and l_o["unit"] == "x"
    assert 0 < l_o["standard_error"] < 0.01
    assert abs(l_o["value"] - 1.15) < 4 * l_o["standard_error"]


def test_force_length_of_a_constant_muscle_is_an_error(tmp_path):
    limb = isowrench.load(str(REPO / "tests" / "data" / "force_model_limb.urdf"))
    with pytest.raises(ValueError, match="muscle 'GP_constant' has the constant force model"):
        isowrench.simulate(limb, str(tmp_path / "x.csv"), effects=["force_length:GP_constant=1.1"])
