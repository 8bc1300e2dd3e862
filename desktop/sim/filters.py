"""Vectorised first-order low-pass (the sensor's bandwidth, 1/f noise shaping).

No scipy: the recursion y[i] = a y[i-1] + (1 - a) x[i] is evaluated in blocks
with the closed form

    y[i] = a^(i+1) y[-1] + (1 - a) a^i sum_{k<=i} a^-k x[k]

where the block length L keeps a^-L below e^30 (no overflow, and the partial
sums lose at most ~L ulp). Blocks start from the previous block's last output,
which is itself the block-local response plus a^L times the block before; after
two blocks that carry is below e^-60 and is dropped.
"""

import numpy as np

_MAX_EXP = 30.0


def alpha(cutoff_hz, rate_hz):
    """Pole a of the discrete first-order low-pass with -3 dB at `cutoff_hz`."""
    return float(np.exp(-2.0 * np.pi * cutoff_hz / rate_hz))


def lowpass(x, a, y0=None):
    """First-order low-pass along axis 0.

    Parameters
    ----------
    x : (N, ...) float array
        Input samples.
    a : float
        Pole, 0 <= a < 1 (see :func:`alpha`); 0 passes x through.
    y0 : (...) array or None
        Output before the first sample (the filter state); None starts at x[0].

    Returns
    -------
    y : (N, ...) float64 array
        Filtered samples; y[-1] is the state to pass to the next call.
    """
    x = np.asarray(x, dtype=float)
    n = x.shape[0]
    if y0 is None:
        y0 = x[0]
    if a <= 0.0 or n == 0:
        return x.copy()
    length = int(max(1, min(n, _MAX_EXP / -np.log(a))))
    nblocks = -(-n // length)
    pad = nblocks * length - n
    xb = np.concatenate([x, np.repeat(x[-1:], pad, axis=0)]) if pad else x
    xb = xb.reshape((nblocks, length) + x.shape[1:])
    shape = (1, length) + (1,) * (x.ndim - 1)
    k = np.arange(length).reshape(shape)
    grow = a ** -k.astype(float)                  # a^-k, at most e^30
    local = (1.0 - a) * np.cumsum(xb * grow, axis=1) / grow   # response from zero state
    decay = a ** (k + 1.0)                        # weight of the state before the block
    ends = local[:, -1]                           # block-local final values
    carry = np.empty((nblocks,) + x.shape[1:])
    carry[0] = y0
    if nblocks > 1:
        aL = a ** length
        carry[1:] = ends[:-1]
        carry[2:] += aL * ends[:-2]
        carry[1] += aL * np.asarray(y0)
        if nblocks > 2:
            carry[2] += aL * aL * np.asarray(y0)
    y = local + decay * carry[:, None]
    return y.reshape((nblocks * length,) + x.shape[1:])[:n]
