"""Backward-pass exposure of the rare exp paths: factors whose e != 0 (their exp is used)."""
import numpy as np
from scipy.spatial.distance import cdist
from tslearn.metrics._soft_dtw import _njit_soft_dtw_grad, _njit_accumulated_matrix_from_distance_matrix
from tslearn.metrics._masks import _njit_compute_mask
import check_exact as ce
mask = _njit_compute_mask(120, 120, 0, None, None)
for name, (P, Q) in ce.sets().items():
    cnt = dict(factors_used=0, specialcase=0, subnormal_result=0, below_m746=0, tiny=0)
    for z, x in zip(P[:40], Q[:40]):
        D = cdist(z, x) ** 2
        R = _njit_accumulated_matrix_from_distance_matrix(D, mask, 0.5)
        E = _njit_soft_dtw_grad(D, R, 0.5)
        for (dr, dc) in ((1, 0), (0, 1), (1, 1)):
            e = E[dr:, dc:][: 120 - 1, : 120 - 1] if True else None
            e = E[dr:120 - 1 + dr, dc:120 - 1 + dc]
            t = ((R[dr:120 - 1 + dr, dc:120 - 1 + dc] - R[:119, :119]) - D[dr:120 - 1 + dr, dc:120 - 1 + dc]) / 0.5
            u = e != 0
            t = t[u]
            with np.errstate(all="ignore"):
                ex = np.exp(t)
            cnt["factors_used"] += int(u.sum())
            cnt["specialcase"] += int(((np.abs(t) >= 512) & (t >= -746)).sum())
            cnt["subnormal_result"] += int(((ex > 0) & (ex < 2.2250738585072014e-308)).sum())
            cnt["below_m746"] += int((t < -746).sum())
            cnt["tiny"] += int((np.abs(t) < 2.0 ** -54).sum())
    print(name, cnt, flush=True)
