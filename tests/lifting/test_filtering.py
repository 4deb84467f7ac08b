import pytest


@pytest.mark.slow
def test_our_butterworth_filtfilt_is_scipys():
    """lowpass does without importing scipy.signal (most of a second at start): same numbers."""
    import numpy as np
    from scipy.signal import butter, filtfilt

    from lifting.filtering import butterworth, lowpass

    for order, wn in [(4, 0.2), (2, 0.5), (4, 0.02)]:
        b1, a1 = butter(order, wn)
        b2, a2 = butterworth(order, wn)
        assert np.allclose(b1, b2, rtol=1e-12, atol=1e-15) and np.allclose(a1, a2, rtol=1e-12, atol=1e-15)
    rng = np.random.default_rng(0)
    for n in (2, 5, 20, 300):
        x = rng.normal(size=(n, 33, 3)).cumsum(0)
        b, a = butter(4, 3 / 15)
        assert np.allclose(lowpass(x, 30, 3.0), filtfilt(b, a, x, axis=0, padlen=min(15, n - 1)), atol=1e-10)


def test_sliding_filters_are_scipy_ndimages():
    import numpy as np
    from scipy.ndimage import maximum_filter1d, percentile_filter, uniform_filter1d

    from lifting.filtering import maximum_1d, mean_1d, percentile_1d

    x = np.random.default_rng(1).normal(size=200)
    for size in (3, 7, 61):
        assert np.array_equal(percentile_1d(x, 10, size), percentile_filter(x, 10, size=size, mode="nearest"))
        assert np.array_equal(maximum_1d(x, size), maximum_filter1d(x, size, mode="nearest"))
        assert np.allclose(mean_1d(x, size), uniform_filter1d(x, size, mode="nearest"), atol=1e-12)


def test_prefetched_reads_ahead_keeps_order_and_raises_the_readers_error():
    import pytest

    from lifting.video import prefetched

    assert list(prefetched(iter(range(50)), depth=3)) == list(range(50))

    def broken():
        yield 1
        raise ValueError("bad frame")

    with pytest.raises(ValueError, match="bad frame"):
        list(prefetched(broken()))
    gen = prefetched(iter(range(1000)), depth=2)
    assert next(gen) == 0
    gen.close()  # stopping early leaves no reader blocked
