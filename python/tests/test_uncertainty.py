"""Model.uncertainty and isowrench.study on local threads: the CLI's numbers, the same bits on any
split of the work, the sweep and fits as tasks, bad input (issue 30)."""

import math
import time

import numpy as np
import pytest

import isowrench
import isowrench.study as study

from conftest import URDF


@pytest.fixture(scope="module")
def rat():
    return isowrench.load(str(URDF / "rat_hindlimb_5dof.urdf"))


INPUTS = ["transducer_stiffness:rz=lognormal:0.5", "angle:hip_rz=normal:2",
          "max_force=normal:0.2", "misalignment=normal:1,1,2"]


def without_seconds(result):
    return {k: v for k, v in result.items() if k != "seconds"}


def test_uncertainty_equals_the_cli_json(rat, cli):
    r = rat.uncertainty("GP", inputs=INPUTS, samples=1000, seed=3)
    args = ["uncertainty", URDF / "rat_hindlimb_5dof.urdf", "--samples", 1000, "--seed", 3,
            "--json"]
    for text in INPUTS:
        args += ["--input", text]
    assert without_seconds(cli(*args)) == without_seconds(r)
    fx = r["postures"][0]["quantities"]["fx"]
    assert fx["unit"] == "N" and fx["count"] == 2000
    assert fx["p2.5"] < fx["p50"] < fx["p97.5"]


def test_study_on_threads_equals_model_uncertainty_bit_for_bit(rat):
    reference = without_seconds(rat.uncertainty("GP", inputs=INPUTS, samples=5000, threads=1))
    for threads, per_task in [(1, 1), (2, 2), (3, 1)]:
        r = study.uncertainty(rat, "GP", inputs=INPUTS, samples=5000, threads=threads,
                              blocks_per_task=per_task)
        assert without_seconds(r) == reference, (threads, per_task)


def test_progress_is_reported(rat):
    seen = []
    study.uncertainty(rat, "GP", inputs=INPUTS[:1], samples=3 * 2048, blocks_per_task=1,
                      progress=lambda done, total: seen.append((done, total)))
    assert seen == [(1, 3), (2, 3), (3, 3)]


def test_sweep_as_tasks_equals_one_batch(rat):
    rng = np.random.default_rng(4)
    Q = np.tile(rat.default_posture, (1001, 1))
    Q[:, 0] += rng.uniform(-0.4, 0.4, 1001)
    Q[:, 3] += rng.uniform(-0.6, 0.6, 1001)
    reference = rat.wrench_batch("GP", Q, threads=1)
    for rows in (4, 100, 333):
        W = study.sweep(rat, "GP", Q, rows_per_task=rows, threads=2)
        assert np.array_equal(W, reference), rows


def test_fit_sessions_equal_single_fits(rat, tmp_path):
    files = []
    for seed in (1, 2):
        path = tmp_path / f"session{seed}.csv"
        isowrench.simulate(rat, str(path), effects=["base_isotropic=3e6"], trials=30, seed=seed)
        files.append(str(path))
    results = study.fit_sessions(rat, files, threads=2)
    assert [r["csv"] for r in results] == files
    for path, r in zip(files, results):
        single = isowrench.fit(rat, path)
        assert r["verdict"] == single["verdict"]
        assert [c["id"] for c in r["chosen"]] == [c["id"] for c in single["chosen"]]
        assert r["chosen"][0]["parameters"][0]["value"] == single["chosen"][0]["parameters"][0]["value"]


def test_bad_input_is_a_value_error_naming_it(rat):
    with pytest.raises(ValueError, match=r"did you mean 'transducer_stiffness'"):
        rat.uncertainty("GP", inputs=["transducer_stifness:x=lognormal:0.5"])
    with pytest.raises(ValueError, match=r"sd -1 must be finite and >= 0"):
        rat.uncertainty("GP", inputs=[{"name": "angle:hip_rz", "sd": -1}])
    with pytest.raises(ValueError, match=r"empty support"):
        study.uncertainty(rat, "GP", inputs=["max_force=uniform:1.2:0.8"])


def test_unreachable_scheduler_is_an_error_within_the_timeout(rat):
    pytest.importorskip("distributed")
    start = time.monotonic()
    with pytest.raises(ConnectionError, match=r"cannot reach the Dask scheduler at tcp://127.0.0.1:9"):
        study.uncertainty(rat, "GP", inputs=INPUTS[:1], samples=100, client="tcp://127.0.0.1:9",
                          connect_timeout=2)
    assert time.monotonic() - start < 10


def test_fit_sessions_pass_the_fit_options(rat, tmp_path):
    # A lab's ';' + decimal-comma sheets and fit options reach every session's fit.
    plain = isowrench.simulate(rat, str(tmp_path / "plain.csv"), effects=["base_isotropic=3e6"],
                               trials=30, seed=4)
    lines = [l for l in open(plain).read().splitlines() if not l.startswith("#")]
    (tmp_path / "excel.csv").write_text(
        "\n".join(l.replace(",", ";").replace(".", ",") for l in lines) + "\n")
    options = dict(delimiter=";", decimal_comma=True, rounds=1,
                   candidates=["base_isotropic", "sensor_offset"])
    [r] = study.fit_sessions(rat, [str(tmp_path / "excel.csv")], threads=1, **options)
    single = isowrench.fit(rat, str(tmp_path / "excel.csv"), **options)
    assert r["verdict"] == single["verdict"] == "explained"
    assert r["chosen"][0]["parameters"][0]["value"] == single["chosen"][0]["parameters"][0]["value"]
    assert len(r["rounds"]) == 1


POINT_INPUTS = ["point:GP:0=normal:1", "point:GP:1:y=normal:0.5", "angle:knee_rz=normal:2"]


def test_point_inputs_equal_the_cli_and_the_study_bit_for_bit(rat, cli):
    # Muscle path points (mm, the point's link frame): the engine's point offsets, no model
    # rebuilt per sample; the numbers of the CLI, and of isowrench.study on any split.
    r = rat.uncertainty("GP", inputs=POINT_INPUTS, samples=3000, seed=5, threads=1)
    args = ["uncertainty", URDF / "rat_hindlimb_5dof.urdf", "--samples", 3000, "--seed", 5,
            "--json"]
    for text in POINT_INPUTS:
        args += ["--input", text]
    assert without_seconds(cli(*args)) == without_seconds(r)
    assert r["groups"] == ["point:GP:0", "point:GP:1:y", "angle:knee_rz"]
    for threads, per_task in [(2, 1), (3, 2)]:
        s = study.uncertainty(rat, "GP", inputs=POINT_INPUTS, samples=3000, seed=5,
                              threads=threads, blocks_per_task=per_task)
        assert without_seconds(s) == without_seconds(r), (threads, per_task)
    # The origin's 1 mm moves the wrench more than the insertion's 0.5 mm along y.
    first = r["postures"][0]["sobol"]["first"]
    assert first["point:GP:0"]["fx"] > first["point:GP:1:y"]["fx"]
    with pytest.raises(ValueError, match=r"unknown path point '2' \(did you mean '1'\?\)"):
        rat.uncertainty("GP", inputs=["point:GP:2=normal:1"])
    with pytest.raises(ValueError, match=r"unknown axis 'q'"):
        rat.uncertainty("GP", inputs=[{"name": "point:GP:0:q", "sd": 1}])


def test_a_force_model_muscle_is_studied_at_each_sampled_activation(cli):
    # Millard2012 with a compliant tendon: W is not proportional to the activation, so each
    # sample's activation goes through the engine. Model.uncertainty equals the CLI and
    # isowrench.study (the model shipped as URDF text keeps its force model).
    limb_path = URDF.parent / "tests" / "data" / "force_model_limb.urdf"
    limb = isowrench.load(str(limb_path))
    inputs = ["activation=uniform:0.3:0.7", "max_force=normal:0.1"]
    r = limb.uncertainty("GP_compliant", inputs=inputs, samples=2500, activation=0.5)
    args = ["uncertainty", limb_path, "--muscle", "GP_compliant", "--activation", 0.5,
            "--samples", 2500, "--json"]
    for text in inputs:
        args += ["--input", text]
    assert without_seconds(cli(*args)) == without_seconds(r)
    s = study.uncertainty(limb, "GP_compliant", inputs=inputs, samples=2500, activation=0.5,
                          threads=2)
    assert without_seconds(s) == without_seconds(r)
    p = r["postures"][0]
    assert p["counts"]["valid"] == 5000
    # The mean lies between the wrenches at activations 0.3 and 0.7 (monotone in a here).
    q = limb.default_posture
    w3 = limb.wrench("GP_compliant", q, activation=0.3).transducer[0]
    w7 = limb.wrench("GP_compliant", q, activation=0.7).transducer[0]
    assert min(w3, w7) < p["quantities"]["fx"]["mean"] < max(w3, w7)
    with pytest.raises(ValueError, match=r"activation \[0.5, 1.2\] leaves \[0, 1\]"):
        limb.uncertainty("GP_compliant", inputs=["activation=uniform:0.5:1.2"])
