"""wrench_batch equals single wrench() calls, row by row."""

import numpy as np
import pytest

import isowrench

from conftest import URDF


# Postures drawn beyond the base dofs' limits on purpose: their plausibility warnings are expected.
@pytest.mark.filterwarnings("ignore:.*outside the joint's limits:UserWarning")
@pytest.mark.parametrize("name", ["rat_hindlimb_5dof.urdf", "rat_hindlimb_6dof.urdf",
                                  "rat_hindlimb_5dof_base.urdf", "rat_hindlimb_coupled_knee.urdf"])
def test_batch_equals_single_calls(name):
    m = isowrench.load(str(URDF / name))
    rng = np.random.default_rng(7)
    n = len(m.coordinates)
    Q = m.default_posture + rng.uniform(-0.5, 0.5, size=(203, n))  # 203: not a multiple of the 4 SIMD lanes
    for muscle in m.muscles:
        W, status = m.wrench_batch(muscle, Q, return_status=True)
        assert W.shape == (203, 6) and W.dtype == np.float64 and W.flags.c_contiguous
        for i in range(Q.shape[0]):
            w = m.wrench(muscle, Q[i])
            assert isowrench.STATUS_NAMES[status[i]] == w.status
            # The batch's SIMD lanes may fuse multiply-adds differently: agreement to rounding,
            # i.e. a few eps times cond(K) relative to |W|.
            scale = max(np.abs(w.transducer).max(), 1e-300)
            assert np.abs(W[i] - w.transducer).max() <= 1e-9 * scale, (i, W[i], w.transducer)


def test_batch_options_follow_single_calls(rat):
    Q = np.tile(rat.default_posture, (9, 1))
    Q[:, 3] += np.linspace(-0.4, 0.4, 9)
    W = rat.wrench_batch("GP", Q, activation=0.5, transducer="jr3", released=["rz"], threads=1)
    for i in range(9):
        w = rat.wrench("GP", Q[i], transducer="jr3", released=["rz"], activation=0.5)
        np.testing.assert_allclose(W[i], w.transducer, rtol=1e-9, atol=1e-15)
    assert np.all(W[:, 5] == 0.0)  # released rz carries no moment


def test_batch_accepts_lists_fortran_order_and_empty(rat):
    Q = np.tile(rat.default_posture, (4, 1))
    expected = rat.wrench_batch("GP", Q)
    np.testing.assert_array_equal(rat.wrench_batch("GP", Q.tolist()), expected)
    np.testing.assert_array_equal(rat.wrench_batch("GP", np.asfortranarray(Q)), expected)
    assert rat.wrench_batch("GP", np.zeros((0, 5))).shape == (0, 6)


def test_activation_scales_the_wrench_linearly(rat):
    # tau = -a F dL/dq and the statics are linear in tau: W(a) = a W(1).
    Q = np.tile(rat.default_posture, (3, 1))
    np.testing.assert_allclose(rat.wrench_batch("GP", Q, activation=0.25), 0.25 * rat.wrench_batch("GP", Q),
                               rtol=1e-12, atol=1e-16)
