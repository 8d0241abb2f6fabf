"""Units and model errors are printed one way for people: superscripts, four decimals."""

from __future__ import annotations

import pytest

from odsuite.domain.display import ascii_unit, error_text, fixed, per_unit, unit_text


@pytest.mark.parametrize("stored, shown", [("m/s^2", "m/s²"), ("(m/s^2)/N", "(m/s²)/N"), ("kg m^2", "kg m²"),
                                           ("m^3", "m³"), ("N/m", "N/m"), ("1", "1")])
def test_stored_units_print_with_superscripts(stored, shown):
    assert unit_text(stored) == shown


@pytest.mark.parametrize("written, stored", [("m/s2", "m/s^2"), ("m/s^2", "m/s^2"), ("m/s**2", "m/s^2"),
                                             ("m/s²", "m/s^2"), (" m/s² ", "m/s^2"), ("(m/s²)/N", "(m/s^2)/N"),
                                             ("kg m2", "kg m^2"), ("s⁻¹", "s^-1"), ("m/s", "m/s"), ("V", "V"),
                                             ("kN", "kN"), ("1", "1")])
def test_units_as_people_write_them_read_back_to_the_stored_spelling(written, stored):
    assert ascii_unit(written) == stored
    assert ascii_unit(unit_text(stored)) == stored


def test_a_sensitivity_per_ratio_unit_is_parenthesised():
    assert per_unit("V", "m/s^2") == "V/(m/s²)"
    assert per_unit("V", "N") == "V/N"
    assert per_unit("V", "um/s^2") == "V/(um/s²)"


def test_an_error_prints_with_four_decimals_as_the_figures_label_it():
    # the history figure labels its bars f"{e:.4f}"; the text says the same number
    assert error_text(0.013417) == "0.0134" == f"{0.013417:.4f}"
    assert error_text(0.46921) == "0.4692"


@pytest.mark.parametrize("value, decimals, shown", [(-0.0, 4, "0.0000"), (-4e-6, 4, "0.0000"), (-0.00051, 3, "-0.001"),
                                                    (0.02, 3, "0.020"), (-12.5, 1, "-12.5"), (float("nan"), 2, "nan")])
def test_a_number_that_rounds_to_zero_prints_without_a_sign(value, decimals, shown):
    # an undamped model's damping ratio printed -0.0000
    assert fixed(value, decimals) == shown
