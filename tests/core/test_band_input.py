"""The band-limited force kept between simulations: the same numbers as computing it again, kept
per record (by its samples), not changeable by a caller."""

import numpy as np

from odsuite.domain.simulation import _band_input, band_limited


def test_kept_band_input_is_the_band_limited_record():
    rng = np.random.default_rng(3)
    u = rng.normal(size=(600, 1))
    first = _band_input(u, 2)
    assert np.array_equal(first, band_limited(u, 2))
    assert _band_input(u.copy(), 2) is first  # the same samples: kept
    assert not first.flags.writeable
    other = u.copy()
    other[10] += 1e-9  # other samples: computed anew
    again = _band_input(other, 2)
    assert again is not first and np.array_equal(again, band_limited(other, 2))
    assert np.abs(again - first).max() > 0
