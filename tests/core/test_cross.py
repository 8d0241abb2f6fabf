"""model.cross: numpy's cross product without its axis handling, to the bit."""

import numpy as np

from odsuite.domain.model import cross


def test_cross_of_two_vectors_is_numpys_to_the_bit():
    rng = np.random.default_rng(11)
    a, b = rng.standard_normal((2, 2000, 3)) * np.exp(rng.uniform(-20, 20, (2, 2000, 1)))
    for x, y in zip(a, b):
        assert np.array_equal(cross(x, y), np.cross(x, y))


def test_stacked_vectors_are_numpys_cross_too():
    # three stacked vectors unpack as three rows: taken as 3-vectors they would give another product
    rng = np.random.default_rng(12)
    for shape in ((3, 3), (5, 3)):
        a, b = rng.standard_normal((2, *shape))
        assert np.array_equal(cross(a, b), np.cross(a, b))
    a, b = rng.standard_normal((2, 3, 3))
    assert np.array_equal(cross(a[0], b), np.cross(a[0], b))
