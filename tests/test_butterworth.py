"""mavsim_core.butterworth: the closed-form design is scipy's, to rounding, over the cutoffs the code uses."""

import numpy as np
import pytest

from mavsim_core.butterworth import lowpass2


@pytest.mark.parametrize(
    "cutoff_hz, sample_hz", [(30.0, 250.0), (40.0, 250.0), (1.0, 250.0), (110.0, 250.0), (5.0, 50.0)]
)
def test_the_coefficients_are_scipys(cutoff_hz, sample_hz):
    from scipy.signal import butter  # here, not at collection: every xdist worker collects every file

    b, a = lowpass2(cutoff_hz, sample_hz)
    sb, sa = butter(2, cutoff_hz, fs=sample_hz)
    assert np.allclose(b, sb, rtol=1e-12, atol=1e-15) and np.allclose(a, sa, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("cutoff_hz", [0.0, -1.0, 125.0, 300.0])
def test_a_cutoff_outside_the_band_is_refused(cutoff_hz):
    with pytest.raises(ValueError, match="cutoff"):
        lowpass2(cutoff_hz, 250.0)
