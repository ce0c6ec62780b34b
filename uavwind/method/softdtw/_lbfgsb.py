"""L-BFGS-B without ``scipy.optimize.minimize``'s layers, for the soft-DTW barycentres.

It drives scipy's own ``setulb`` routine with the arguments ``minimize(method="L-BFGS-B")``
would pass, so its final ``x`` is bit-identical (tested); the layers it skips cost about
0.7 ms per call. ``setulb`` is a private scipy routine: :data:`SCIPY_TESTED` names the
scipy versions this call was checked against, and another version falls back to
``scipy.optimize.minimize`` (same result, a little slower) with a warning.
"""


import numpy as np




#: scipy versions whose private ``setulb`` signature this driver was checked against
#: (bit-identical to ``minimize`` in ``tests/test_softdtw.py``).
SCIPY_TESTED = ("1.17",)
_SCIPY_OK = None


def scipy_supported():
    """Whether the installed scipy is one :data:`SCIPY_TESTED` names (warns once if not)."""
    global _SCIPY_OK
    if _SCIPY_OK is None:
        import scipy
        _SCIPY_OK = scipy.__version__.startswith(SCIPY_TESTED)
        if not _SCIPY_OK:
            import warnings
            warnings.warn(f"scipy {scipy.__version__} is not one the L-BFGS-B driver was tested "
                          f"with ({', '.join(SCIPY_TESTED)}): using scipy.optimize.minimize "
                          "(the same result, slower)", RuntimeWarning, stacklevel=2)
    return _SCIPY_OK


def lbfgsb(fg, x0, maxiter, ftol, gtol):
    """Minimise ``fg(x) -> (f, g)`` from ``x0`` with L-BFGS-B as
    ``scipy.optimize.minimize(method="L-BFGS-B", jac=True, options={"maxiter", "ftol",
    "gtol"})`` does: through :func:`_lbfgsb` on a tested scipy, through ``minimize``
    itself otherwise."""
    if scipy_supported():
        return _lbfgsb(fg, x0, maxiter, ftol, gtol)
    from scipy.optimize import minimize
    return minimize(fg, x0, method="L-BFGS-B", jac=True,
                    options={"maxiter": maxiter, "ftol": ftol, "gtol": gtol}).x


def lbfgsb_many(fg_many, x0s, maxiter, ftol, gtol):
    """Minimise several problems side by side: ``fg_many([(k, x), ...]) -> [(f, g), ...]``
    evaluates problem k at x for every problem still running, in one call (so one kernel
    call can serve them all). Each problem sees exactly the evaluations :func:`lbfgsb`
    would give it, in the same order, so each final ``x`` is the same array; on an untested
    scipy, one ``minimize`` after another."""
    return lbfgsb_many_known(fg_many, x0s, [None] * len(x0s), maxiter, ftol, gtol)[0]


def lbfgsb_many_known(fg_many, x0s, known, maxiter, ftol, gtol):
    """:func:`lbfgsb_many`, told what is already known: ``known[k]``, if not None, is
    ``(f, g)`` of problem k at its start ``x0s[k]`` (an evaluation made before, at that point
    exactly: a k-means round's barycentre starts where the last round's ended, and when the
    cluster kept its series the objective there is the one the last round's run ended on), so
    that evaluation is not asked of ``fg_many``. The run is otherwise the same, so each final
    ``x`` is the one :func:`lbfgsb_many` gives (tested). Returns ``(xs, finals)``:
    ``finals[k]`` is ``(f, g)`` at ``xs[k]`` when the run ended at the point it last evaluated
    (as it does when it converges or reaches ``maxiter``), else None; on an untested scipy
    ``known`` is not used and every final is None."""
    if len(known) != len(x0s):
        raise ValueError(f"known must give one entry per start, got {len(known)} for "
                         f"{len(x0s)} starts")
    if not scipy_supported():
        return ([lbfgsb(lambda x, k=k: fg_many([(k, x)])[0], x0, maxiter, ftol, gtol)
                 for k, x0 in enumerate(x0s)], [None] * len(x0s))
    runs = [_lbfgsb_steps(x0, maxiter, ftol, gtol) for x0 in x0s]
    asked = {k: next(run) for k, run in enumerate(runs)}
    out, finals = [None] * len(runs), [None] * len(runs)

    def answer(k, fg):
        try:
            asked[k] = runs[k].send(fg)
        except StopIteration as done:
            out[k], finals[k] = done.value
            del asked[k]

    for k, fg in enumerate(known):
        if fg is not None:  # the first point asked is the start itself
            answer(k, fg)
    while asked:
        order = list(asked)
        for k, fg in zip(order, fg_many([(k, asked[k]) for k in order])):
            answer(k, fg)
    return out, finals


def _lbfgsb(fg, x0, maxiter, ftol, gtol, maxcor=10, maxls=20):
    """:func:`_lbfgsb_steps` driven by ``fg``: the final ``x``."""
    run = _lbfgsb_steps(x0, maxiter, ftol, gtol, maxcor, maxls)
    try:
        x = next(run)
        while True:
            x = run.send(fg(x))
    except StopIteration as done:
        return done.value[0]


def _lbfgsb_steps(x0, maxiter, ftol, gtol, maxcor=10, maxls=20):
    """Unconstrained L-BFGS-B: the loop of scipy's ``_minimize_lbfgsb`` without
    the ``minimize`` / ``ScalarFunction`` / ``MemoizeJac`` layers around it, as a
    generator: it yields each point to evaluate (a copy) and is sent ``(f, g)`` there;
    it returns ``(x, fg)``: the final ``x``, and the ``(f, g)`` it was sent at ``x`` when
    ``x`` is the point it last evaluated (else None: setulb restored an earlier point).

    Calls the same Fortran-derived ``setulb`` with the same arguments, feeds it
    the same (f, g) at the same points (an evaluation is reused when ``setulb``
    asks again at the point it last saw, as ``ScalarFunction`` does), and so
    returns the bit-identical final ``x`` (tested against ``scipy.optimize.minimize``).
    Those layers cost about 0.7 ms per call, some 15% of a loop with barycentres
    of 10 series of 120 samples.
    """
    from scipy.optimize import _lbfgsb as lb

    n = x0.size
    m = maxcor
    factr = ftol / np.finfo(float).eps
    nbd = np.zeros(n, np.int32)
    low_bnd = np.zeros(n, np.float64)
    upper_bnd = np.zeros(n, np.float64)
    x = np.array(x0, dtype=np.float64).ravel()
    f = np.array(0.0, dtype=np.float64)
    g = np.zeros((n,), dtype=np.float64)
    wa = np.zeros(2 * m * n + 5 * n + 11 * m * m + 8 * m, np.float64)
    iwa = np.zeros(3 * n, dtype=np.int32)
    task = np.zeros(2, dtype=np.int32)
    ln_task = np.zeros(2, dtype=np.int32)
    lsave = np.zeros(4, dtype=np.int32)
    isave = np.zeros(44, dtype=np.int32)
    dsave = np.zeros(29, dtype=np.float64)
    # ScalarFunction evaluates at x0 when it is built; later evaluations happen only
    # where x has changed since the last one
    last_x = x.copy()
    last_f, last_g = yield last_x.copy()
    n_iterations = 0
    while True:
        g = g.astype(np.float64)
        lb.setulb(m, x, low_bnd, upper_bnd, nbd, f, g, factr, gtol, wa, iwa, task,
                  lsave, isave, dsave, maxls, ln_task)
        if task[0] == 3:
            if not (x == last_x).all():  # np.array_equal of two arrays of one shape
                last_x = x.copy()
                last_f, last_g = yield last_x.copy()
            f, g = last_f, last_g
        elif task[0] == 1:
            n_iterations += 1
            if n_iterations >= maxiter:
                task[0] = 5
                task[1] = 504
        else:
            break
    return x, ((last_f, last_g) if (x == last_x).all() else None)
