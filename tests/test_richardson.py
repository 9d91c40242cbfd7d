"""Richardson extrapolation and observed order (sphfem.validation.richardson) on
manufactured sequences f(h) = f0 + C h^p (+ a higher-order term)."""

import math

import pytest

from sphfem.validation.richardson import observed_order, richardson


@pytest.mark.parametrize("p", [1.0, 1.5, 2.0, 3.0])
@pytest.mark.parametrize("hs", [(4.0, 2.0, 1.0), (10.0, 6.25, 3.125), (3.0, 2.0, 1.0)])
def test_exact_power_law_recovers_order_and_limit(p, hs):
    f0, C = 3.7, -0.8
    f = [f0 + C * h**p for h in hs]
    est = richardson(hs, f)
    assert est.asymptotic
    assert est.order == pytest.approx(p, rel=1e-9)
    assert est.value == pytest.approx(f0, rel=1e-12)
    # the GCI band around the finest value holds the exact limit (F_s = 1.25 > 1)
    assert abs(est.finest - f0) <= est.error_bar
    assert est.relative_error_finest == pytest.approx(abs(C) * hs[-1]**p / f0, rel=1e-9)


def test_input_order_does_not_matter_and_four_levels_report_each_triple():
    hs = [1.0, 8.0, 2.0, 4.0]
    f = [2.0 + 0.5 * h**2 + 0.01 * h**3 for h in hs]
    est = richardson(hs, f)
    assert len(est.orders) == 2
    # the higher-order term fades: the finer triple is closer to 2
    assert abs(est.orders[1] - 2.0) < abs(est.orders[0] - 2.0)
    assert abs(est.value - 2.0) < 0.05 * abs(est.finest - 2.0) + 1e-3


def test_oscillatory_sequence_is_not_asymptotic_and_gets_spread_error_bar():
    est = richardson([4, 2, 1], [1.0, 1.2, 1.1])
    assert not est.asymptotic and est.order is None
    assert est.value == 1.1
    assert est.error_bar == pytest.approx(3.0 * 0.2)
    assert "oscillatory" in est.note


def test_diverging_sequence_is_flagged():
    assert observed_order([4, 2, 1], [1.0, 1.1, 1.4]) is None
    est = richardson([4, 2, 1], [1.0, 1.1, 1.4])
    assert not est.asymptotic and "not converging" in est.note


def test_converged_to_round_off():
    est = richardson([4, 2, 1], [5.0, 5.0, 5.0])
    assert est.asymptotic and est.error_bar == 0.0 and est.value == 5.0


def test_within_uses_error_bar():
    est = richardson([4, 2, 1], [1.0 + 0.1 * h for h in (4, 2, 1)])
    assert est.within(1.05, 0.0)           # inside the error bar (finest 1.1, limit 1.0)
    assert not est.within(1.3, 0.05)


@pytest.mark.parametrize("bad, msg", [(([1, 2], [1, 2]), "at least 3"),
                                      (([1, 2, 3], [1, 2]), "spacings but"),
                                      (([1, 2, 3], [1, math.nan, 2]), "non-finite"),
                                      (([1, 1, 2], [1, 2, 3]), "distinct")])
def test_bad_input(bad, msg):
    with pytest.raises(ValueError, match=msg):
        richardson(*bad)


def test_implausible_order_is_not_asymptotic():
    """Differences shrinking by 2^10 per halving are chance, not an order of 10."""
    est = richardson([4, 2, 1], [2.5, 1.96, 1.96 - 0.54 / 2**10])
    assert not est.asymptotic and "implausible" in est.note
    assert est.error_bar == pytest.approx(3.0 * 0.54, rel=0.01)


def test_formal_order_caps_the_observed_one():
    """Roache's rule: an observed order above the formal one is replaced by it, also one
    above MAX_ORDER (the coarse level ahead of the asymptotic range); below it, nothing
    changes; oscillatory sequences keep the 3x-spread bar."""
    h, f = [4, 2, 1], [2.5, 1.96, 1.96 - 0.54 / 2**10]
    est = richardson(h, f, formal_order=2.0)
    assert est.asymptotic and est.order == 2.0 and "formal order used" in est.note
    e32 = f[2] - f[1]
    assert est.value == pytest.approx(f[2] + e32 / 3.0)  # r = 2, p = 2: r^p - 1 = 3
    assert est.error_bar == pytest.approx(1.25 * abs(e32) / 3.0)
    # an exact first-order sequence: the cap at 2 is not reached
    g = [1.0 + 0.1 * x for x in h]
    assert richardson(h, g, formal_order=2.0).order == pytest.approx(1.0)
    # an exact third-order sequence capped at 2: a larger error estimate than its own
    g3 = [1.0 + 0.1 * x**3 for x in h]
    own, capped = richardson(h, g3), richardson(h, g3, formal_order=2.0)
    assert own.order == pytest.approx(3.0) and capped.order == 2.0
    assert capped.error_bar > own.error_bar
    osc = richardson(h, [1.0, 1.1, 1.05], formal_order=2.0)
    assert not osc.asymptotic and osc.error_bar == pytest.approx(3.0 * 0.1)
    with pytest.raises(ValueError, match="formal_order"):
        richardson(h, g, formal_order=0.0)


def test_an_oscillation_within_the_noise_is_not_classified():
    """Ensemble means 57.7, 47.1, 47.3 (the finest step +0.2 against a sampling half-width
    of 2.4 per level): not an oscillation the data can show, so the formal order gives the
    estimate; a significant oscillation keeps the 3x-spread bar; noise needs a formal order."""
    h, f = [1.56, 1.11, 0.78], [57.7, 47.1, 47.3]
    plain = richardson(h, f, formal_order=2.0)
    assert not plain.asymptotic and plain.error_bar == pytest.approx(3.0 * 10.6)
    est = richardson(h, f, formal_order=2.0, noise=[2.4, 2.4, 2.4])
    assert est.asymptotic and est.order == 2.0 and "within the sampling noise" in est.note
    r = 1.11 / 0.78
    assert est.value == pytest.approx(47.3 + 0.2 / (r**2 - 1.0))
    assert est.error_bar == pytest.approx(1.25 * 0.2 / (r**2 - 1.0))
    # the input order does not matter: the noise follows its level
    assert richardson(h[::-1], f[::-1], 2.0, [2.4] * 3).value == pytest.approx(est.value)
    loud = richardson(h, [57.7, 47.1, 52.3], formal_order=2.0, noise=[2.4, 2.4, 2.4])
    assert not loud.asymptotic and "oscillatory" in loud.note
    with pytest.raises(ValueError, match="noise needs a formal_order"):
        richardson(h, f, noise=[1.0] * 3)
    with pytest.raises(ValueError, match="noise half-widths"):
        richardson(h, f, 2.0, noise=[1.0] * 2)
