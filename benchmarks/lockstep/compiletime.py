import time, numpy as np
t0 = time.time()
import lockW, lockG
from lockV import N
t1 = time.time()
gv, b, _, _ = lockW.make(4)
XG = np.zeros((1, 120 * 3 * N)); out = np.empty((1, N))
b(XG, XG, 120, 120, 3, 0.5, out)
t2 = time.time()
fwd, og, _ = lockG.make(4, True, True)
Z = np.zeros((120, 3)); Xs = np.zeros((N, 120, 3))
ZL, XGg = lockG.prep(Z, Xs)
og(Z, Xs, ZL, XGg, 0.5, np.empty(N), np.empty((N, 120, 3)), *lockG.workspace(120, 120))
t3 = time.time()
print(f"import {t1 - t0:.1f} s, cold compile value kernel {t2 - t1:.1f} s, objgrad kernel {t3 - t2:.1f} s")
