"""SubspaceModel.simulate_segments against an independent segment-by-segment computation."""

import numpy as np
import scipy.signal as sig
from sysid_plants import two_mode_plant

from gbpipe.sysid import SubspaceModel


def model_of(A, B, C, D):
    n, l_ = A.shape[0], C.shape[0]
    return SubspaceModel(A=A, B=B, C=C, D=D, K=np.zeros((n, l_)), noise_cov=np.eye(l_),
                         singular_values=np.ones(n), dt=1.0, method="moesp", order=n)


def test_batched_segments_recover_each_segment_initial_state():
    # Noise-free output of the true plant whose state is reset at every segment start: the
    # least-squares initial states are exactly those states and the fit is exact.
    A, B, C, D = two_mode_plant()
    model = model_of(A, B, C, D)
    rng = np.random.default_rng(5)
    seg, n_seg = 300, 7
    u = rng.standard_normal(seg * n_seg - 120)  # the last segment is shorter
    x0 = rng.standard_normal((n_seg, 4))
    y = np.concatenate([sig.dlsim((A, B, C, D, 1.0), u[k * seg:(k + 1) * seg], x0=x0[k])[1]
                        for k in range(n_seg)])
    y_sim, x0_est = model.simulate_segments(u, y, seg)
    np.testing.assert_allclose(x0_est, x0, atol=1e-8)
    np.testing.assert_allclose(y_sim, y, atol=1e-8 * np.abs(y).max())


def test_batched_segments_match_estimate_x0_per_segment_on_noisy_data():
    A, B, C, D = two_mode_plant()
    model = model_of(A, B, C, D)
    rng = np.random.default_rng(6)
    u = rng.standard_normal(2500)
    y = sig.dlsim((A, B, C, D, 1.0), u)[1] + 0.3 * rng.standard_normal((2500, 1))
    y_sim, x0 = model.simulate_segments(u, y, 400)
    for k, a in enumerate(range(0, 2500, 400)):
        ref_x0 = model.estimate_x0(u[a:a + 400], y[a:a + 400])
        np.testing.assert_allclose(x0[k], ref_x0, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(y_sim[a:a + 400], model.simulate(u[a:a + 400], ref_x0),
                                   rtol=1e-9, atol=1e-9)
