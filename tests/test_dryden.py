"""Dryden turbulence: MIL-F-8785C against closed forms, the cited code quirk by quirk."""
import math

import numpy as np
import pytest
import scipy.signal as sg
from scipy.signal import welch

import uavwind as uw
from uavwind.sim.cited_dryden import CitedDryden, cited_dryden_parameters, cited_transfer_functions
from uavwind.sim.mil_dryden import FEET, dryden_parameters, dryden_psd


@pytest.mark.parametrize("kwargs, err, match", [
    ({"w20": [0.0]}, ValueError, "w20"), ({"w20": [-3.0]}, ValueError, "w20"),
    ({"w20": [np.nan]}, ValueError, "w20"), ({"w20": [[1.0]]}, ValueError, "w20"),
    ({"w20": [12.0], "altitude": 0.0}, ValueError, "altitude"),
    ({"w20": [12.0], "dt": 0.0}, ValueError, "dt"),
    ({"w20": [12.0], "airspeed": -1.0}, ValueError, "airspeed"),
    ({"w20": [12.0, 11.0], "airspeed": [1.0, 2.0, 3.0]}, ValueError, "airspeed"),
    ({"w20": [12.0], "seed": "x"}, TypeError, "seed"),
    ({"w20": [12.0], "discretisation": "tustin"}, TypeError, "discretisation"),
])
def test_dryden_validation(kwargs, err, match):
    with pytest.raises(err, match=match):
        uw.DrydenWind(**kwargs)


def test_dryden_parameters_match_mil_f_8785c():
    h_ft = 10.0 / FEET
    p = dryden_parameters(12.0, 10.0)
    base = 0.177 + 0.000823 * h_ft
    assert math.isclose(p["sigma_w"], 1.2)
    assert math.isclose(p["sigma_u"], 1.2 / base ** 0.4)
    assert p["sigma_u"] == p["sigma_v"]
    assert math.isclose(p["L_w"], 10.0)
    assert math.isclose(p["L_u"], h_ft / base ** 1.2 * FEET)
    # altitude clamped to [10, 1000] ft
    assert dryden_parameters(12.0, 1.0)["L_w"] == pytest.approx(10 * FEET)
    assert dryden_parameters(12.0, 5000.0)["L_w"] == pytest.approx(1000 * FEET)


N_ENS = 4000


W20 = 12.5


@pytest.fixture(scope="module")
def ensemble():
    w = uw.DrydenWind(np.full(N_ENS, W20), altitude=10.0, dt=0.1, seed=2024)
    return w, w.gusts(121)


def test_dryden_ensemble_sigma_from_the_first_second(ensemble):
    w, g = ensemble
    sig = w.sigmas[0]
    std = g.std(axis=0)  # (time, axis) across environments
    assert np.all(np.abs(std[:10] / sig - 1) < 0.05), std[:10] / sig  # stationary from t = 0
    assert np.all(np.abs(std / sig - 1) < 0.05)
    assert np.all(np.abs(g.mean(axis=0)) < 0.1 * sig)  # zero mean


def test_dryden_u_autocorrelation_at_one_second(ensemble):
    w, g = ensemble
    p = w.parameters
    rho = np.corrcoef(g[:, 0, 0], g[:, 10, 0])[0, 1]
    assert rho == pytest.approx(math.exp(-W20 * 1.0 / p["L_u"][0]), abs=0.03)


def test_dryden_discrete_variance_is_sigma_squared():
    """White noise of std sqrt(pi/dt) makes the stationary output variance sigma^2."""
    from uavwind.sim.mil_dryden import _stationary_covariance

    w = uw.DrydenWind([11.18, 12.5, 13.86], dt=0.1, seed=0)
    for j, ax in enumerate("uvw"):
        A, B, C = w.filters[ax]
        P = _stationary_covariance(A, B, math.pi / 0.1)
        var = np.einsum("ni,nij,nj->n", C, P, C)
        assert np.allclose(var / w.sigmas[:, j] ** 2, 1, atol=0.03)


def test_dryden_spectrum_matches_analytic():
    w = uw.DrydenWind(np.full(200, W20), dt=0.1, seed=11)
    g = w.gusts(2048)
    f, S = welch(g, fs=10.0, nperseg=512, axis=1)  # one-sided, per Hz
    S = S.mean(axis=0)  # (freq, axis)
    band = (f > 0.05) & (f < 1.0)
    p = w.parameters
    for j, ax in enumerate("uvw"):
        analytic = dryden_psd(2 * np.pi * f[band], p[f"sigma_{ax}"][0], p[f"L_{ax}"][0], W20, ax)
        ratio = S[band, j] / (2 * np.pi) / analytic
        assert np.all(np.abs(ratio - 1) < 0.15), (ax, ratio)
        assert abs(ratio.mean() - 1) < 0.05


def test_dryden_psd_integrates_to_variance():
    from scipy.integrate import quad
    for ax in "uvw":
        val, _ = quad(lambda om: dryden_psd(om, 2.0, 60.0, 12.0, ax), 0, np.inf, limit=200)
        assert val == pytest.approx(4.0, rel=1e-6)


def test_dryden_seeds_repeat_and_differ():
    a = uw.DrydenWind([12.0, 13.0], seed=5).gusts(120)
    b = uw.DrydenWind([12.0, 13.0], seed=5).gusts(120)
    c = uw.DrydenWind([12.0, 13.0], seed=6).gusts(120)
    assert np.array_equal(a, b)
    assert not np.allclose(a, c)
    # adding environments keeps the gusts of the existing ones
    d = uw.DrydenWind([12.0, 13.0, 11.5], seed=5).gusts(120)
    assert np.array_equal(a, d[:2])
    # lazy extension draws the same numbers as one long draw
    w = uw.DrydenWind([12.0, 13.0], seed=5)
    w.gusts(10)
    w.velocity(30.0, np.zeros((2, 3)))
    assert np.array_equal(w.gusts(400), uw.DrydenWind([12.0, 13.0], seed=5).gusts(400))


def _zoh_first_order(T, dt):
    """Exact zero-order-hold discretisation of ``1/(1 + T s)``, vectorised over T.

    ``H(z) = (1 - a) / (z - a)`` with ``a = exp(-dt/T)``; returns
    ``num (n, 1), den (n, 2)`` (descending powers of z, ``den[:, 0] = 1``).
    """
    a = np.exp(-dt / T)
    return (1 - a)[:, None], np.stack([np.ones_like(a), -a], axis=1)


def _zoh_second_order(T, dt):
    """Exact ZOH of ``(1 + sqrt(3) T s)/(1 + T s)^2`` = ``sqrt3/(1+Ts) + (1-sqrt3)/(1+Ts)^2``.

    With states x1 = w/(1+Ts), x2 = w/(1+Ts)^2 the sampled system is
    ``A = a [[1, 0], [h/T, 1]]``, ``B = [1 - a, 1 - a (1 + h/T)]``,
    ``C = [sqrt3, 1 - sqrt3]`` (a = exp(-h/T)), whose transfer function
    ``C (zI - A)^-1 B`` is returned as ``num (n, 2), den (n, 3)``.
    """
    ph = dt / T
    a = np.exp(-ph)
    b1, b2 = 1 - a, 1 - a * (1 + ph)
    c1, c2 = math.sqrt(3), 1 - math.sqrt(3)
    num = np.stack([c1 * b1 + c2 * b2, a * (c2 * ph * b1 - c1 * b1 - c2 * b2)], axis=1)
    den = np.stack([np.ones_like(a), -2 * a, a * a], axis=1)
    return num, den


def test_dryden_control_discretisation_equals_the_closed_form_zoh():
    """python-control's sample_system(..., 'zoh') equals the closed-form ZOH of eqs 10-12
    to 1e-12, and gusts from the closed form equal the wind's to 1e-8."""
    from uavwind.sim.mil_dryden import _canonical, dryden_gain

    w20 = np.linspace(11.18, 13.86, 7)
    w = uw.DrydenWind(w20, seed=9)
    p, V, dt = w.parameters, w.airspeed, w.dt
    T = {ax: p[f"L_{ax}"] / V for ax in "uvw"}
    closed = {"u": _zoh_first_order(T["u"], dt), "v": _zoh_second_order(T["v"], dt),
              "w": _zoh_second_order(T["w"], dt)}
    for ax in "uvw":
        gain = np.array([dryden_gain(p[f"sigma_{ax}"][i], p[f"L_{ax}"][i], V[i], ax)
                         for i in range(len(w20))])
        num, den = closed[ax]
        num = num * gain[:, None]
        got_num, got_den = w.transfer_functions[ax]
        assert np.allclose(num, got_num, rtol=1e-12, atol=1e-14)
        assert np.allclose(den, got_den, rtol=1e-12, atol=1e-14)
        A, B, C = _canonical(num, den)
        assert np.allclose(C, w.filters[ax][2], rtol=1e-12, atol=1e-14)


def test_dryden_transfer_functions_are_eqs_10_12():
    Hu, Hv, Hw = uw.dryden_transfer_functions(2.0, 2.0, 1.2, 60.0, 60.0, 3.0, 12.0)
    s = 0.7j
    T = 60.0 / 12.0
    assert complex(Hu(s)) == pytest.approx(2.0 * math.sqrt(2 * 60 / (math.pi * 12)) / (1 + T * s))
    assert complex(Hv(s)) == pytest.approx(
        2.0 * math.sqrt(60 / (math.pi * 12)) * (1 + math.sqrt(3) * T * s) / (1 + T * s) ** 2)
    Tw = 3.0 / 12.0
    assert complex(Hw(s)) == pytest.approx(
        1.2 * math.sqrt(3 / (math.pi * 12)) * (1 + math.sqrt(3) * Tw * s) / (1 + Tw * s) ** 2)


def test_cited_sigmas_and_scale_lengths_follow_the_code_as_written():
    p = cited_dryden_parameters(15.0, 10.0, 12.0)
    h = 10.0 * 3.28084
    assert p["h"] == h and p["V"] == 12.0 * 3.28084
    assert p["sigma_w"] == pytest.approx(1.5)
    assert p["sigma_u"] == p["sigma_v"] == pytest.approx(1.5 / (0.177 + 0.000823 * h) ** 0.4)
    assert p["L_u"] == p["L_v"] == pytest.approx(h / (0.177 + 0.000823 * h) ** 0.2)
    assert p["L_w"] == h
    old = cited_dryden_parameters(15.0, 10.0, 12.0, CitedDryden(length_constant=0.00823))
    assert old["L_u"] == pytest.approx(h / (0.177 + 0.00823 * h) ** 0.2)
    w = uw.DrydenWind([12.0], variant="cited")
    assert w.sigmas[0] == pytest.approx(0.305 * np.array([p["sigma_u"], p["sigma_v"], 1.5]))


def test_cited_gusts_equal_scipy_lsim_of_the_published_code():
    """The control.tf + forced_response path against the cited code's own computation."""
    o = CitedDryden()
    got = uw.cited_gusts(15.0, 10.0, 12.0, o)
    t = np.linspace(0, 5, 1000)
    for j, H in enumerate(cited_transfer_functions(15.0, 10.0, 12.0, o)):
        np.random.seed(o.seeds[j])  # the published code seeds the global generator
        u = 10 * np.random.normal(0, 1, size=1000)
        tf = sg.TransferFunction(np.ravel(H.num[0][0]), np.ravel(H.den[0][0]))
        y = sg.lsim(tf, u, t)[1] * 0.305
        assert np.allclose(got[:, j], y, rtol=1e-9, atol=1e-12)


def test_cited_fixed_seeds_give_every_environment_the_same_gusts():
    w = uw.DrydenWind([11.5, 12.5, 13.5], airspeed=12.0, variant="cited", seed=1)
    g = w.gusts(120)
    assert np.array_equal(g[0], g[1]) and np.array_equal(g[1], g[2])
    assert np.array_equal(g, uw.DrydenWind([11.5, 12.5, 13.5], airspeed=12.0, variant="cited",
                                           seed=99).gusts(120))  # seed ignored
    # the 5 s series repeats (sample index int(t * 200) % 1000)
    rate = w.cited.rate
    assert np.array_equal(w.velocity(5.0, np.zeros((3, 3))), w.velocity(0.0, np.zeros((3, 3))))
    assert np.array_equal(w.velocity(7.3, np.zeros((3, 3))),
                          w._gusts._series[:, int(7.3 * rate) % 1000])


def test_cited_seed_per_environment_and_base_wind():
    o = CitedDryden(turbulence_level=None, seeds=None, base_direction=(1.0, 1.0, 0.0))
    w = uw.DrydenWind([12.0, 12.0], variant="cited", cited=o, seed=5)
    g = w.gusts(1000)
    assert not np.array_equal(g[0], g[1])
    assert np.array_equal(g, uw.DrydenWind([12.0, 12.0], variant="cited", cited=o,
                                           seed=5).gusts(1000))
    mean = g.mean(axis=1)
    assert np.allclose(mean[:, :2], 12.0 / np.sqrt(2), atol=0.5)
    assert np.allclose(mean[:, 2], 0.0, atol=0.5)


@pytest.mark.parametrize("kwargs, match", [
    ({"turbulence_level": 0.0}, "turbulence_level"), ({"seeds": (1, 2)}, "seeds"),
    ({"grid_samples": 1}, "grid_samples"), ({"grid_duration": 0.0}, "grid_duration"),
    ({"base_direction": (0, 0, 0)}, "base_direction"), ({"output_scale": -1}, "output_scale"),
])
def test_bad_cited_options_name_the_parameter(kwargs, match):
    with pytest.raises(ValueError, match=match):
        CitedDryden(**kwargs)


def test_dryden_variant_is_validated():
    with pytest.raises(ValueError, match="variant"):
        uw.DrydenWind([12.0], variant="karman")
    with pytest.raises(TypeError, match="cited"):
        uw.DrydenWind([12.0], variant="cited", cited={"turbulence_level": 3})


def test_a_reseeded_dryden_wind_is_the_wind_made_with_that_seed():
    """with_seed draws what the constructor draws for that seed (a setting checks a group's
    model once and reseeds it per loop); another seed draws other gusts; a model with no
    gusts is its own reseeding."""
    base = uw.DrydenWind([5.0, 12.0], altitude=10.0, seed=0)
    for seed in (lambda: 3, lambda: np.random.SeedSequence(7)):  # a SeedSequence spawns once
        again = base.with_seed(seed())
        made = uw.DrydenWind([5.0, 12.0], altitude=10.0, seed=seed())
        assert np.array_equal(again.gusts(50), made.gusts(50))
        assert np.array_equal(again.sigmas, made.sigmas)
    assert not np.array_equal(base.with_seed(1).gusts(50), base.with_seed(2).gusts(50))
    assert np.array_equal(base.gusts(50), uw.DrydenWind([5.0, 12.0], seed=0).gusts(50))
    const = uw.ConstantWind([[1.0, 0.0, 0.0]])
    assert const.with_seed(5) is const
    with pytest.raises(TypeError, match="seed must be an int"):
        base.with_seed("3")


def test_a_settings_turbulence_follows_its_seed():
    setting = uw.make_setting("light turbulence", "strong turbulence", 3)
    a, b, c = setting.simulate(uw.PAPER_EXAMPLE, seed=1), setting.simulate(
        uw.PAPER_EXAMPLE, seed=1), setting.simulate(uw.PAPER_EXAMPLE, seed=2)
    assert np.array_equal(a, b) and not np.array_equal(a, c)
