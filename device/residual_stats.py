"""The residuals of a calibration session at its finish: their batch means and recent pairs.

    means, counts = batch_means(gates.batches, cal, t)            # mean |h_c| - F per batch, nT
    rho, pairs, rate, white, turn_sd = recent_pairs(gates, cal)   # the last HIST samples' pairs

Imported by session.py after the final solve, not with the session: a board's heap is
shortest while the session collects and solves (a quick re-calibration on a Pico's 190 KB,
docs/limits.md), and this code is only read once.
"""

import math

from residuals import WIDTH

_MIN_PAIRS = 50      # consecutive residual pairs before their correlation counts


def batch_means(rb, cal, t=0.0):
    """([mean |h_c| - F per batch, nT], [its samples]) under cal (sum units, as the fit's),
    of the samples at t tau steps (lagfit.py; 0: as de-lagged), the open batch's included:
    (|h_c|^2 - F^2) / 2F, with h - o = v + d, v = h - c, d = c - o: v^T G v + 2 (G d).v +
    d^T G d, G = M^T M."""
    rb.flush()
    mat = cal.matrix
    g = [[sum(mat[r][a] * mat[r][b] for r in range(3)) for b in range(3)] for a in range(3)]
    d = [rb.centre[a] - cal.offset[a] for a in range(3)]
    gd = [sum(g[a][b] * d[b] for b in range(3)) for a in range(3)]
    const = sum(d[a] * gd[a] for a in range(3)) - cal.field * cal.field
    two_f = 2.0 * cal.field
    # the weights of the 9 sums: 2 G d for the linear ones, G (twice off the diagonal)
    wt = [2.0 * gd[0], 2.0 * gd[1], 2.0 * gd[2]]
    for a in range(3):
        for b in range(a, 3):
            wt.append(g[a][b] if a == b else 2.0 * g[a][b])
    nodes = rb.width > WIDTH
    means = []
    counts = []
    s = rb.sums
    for i in range(rb.cur + 1):
        n = rb.counts[i]
        if not n:
            continue
        j = i * rb.width
        q = 0.0
        for k in range(WIDTH):
            v = s[j + k]
            if nodes:
                v += t * (s[j + WIDTH + k] + t * s[j + 2 * WIDTH + k])
            q += wt[k] * v
        means.append((q / n + const) / two_f)
        counts.append(n)
    return means, counts


def recent_pairs(g, cal):
    """(rho, pairs, rate, white, turn_sd) of the residuals |h_c| - F of consecutive accepted
    samples among the last HIST (the gates' removal history), against the final fit: their
    lag-1 correlation, the pairs' correlation with the squared turn between them, their
    white noise (sqrt of half the mean square successive difference) and the spread of the
    squared turn; None where too few pairs (_MIN_PAIRS) or no spread tell it.

    A sensor that lags the turn (a bandwidth set too high for it), a field that wanders or
    a flexing mount leave residuals that follow each other from sample to sample (rho near
    1; their correlation over the whole session widens the predicted error: ResidualBatches).
    Against the final fit, not a provisional one: a provisional fit's own error, smooth in
    orientation, would read as correlation when the turn is slow.

    Which of those it is: a sensor that lags reads |h| short by B (tau w)^2 / 2 at a turn
    rate w, so its residuals fall as the turn between samples grows (|dv|^2 / |v|^2 ~ w^2,
    in codes: the gains' few percent do not change the sign); a wandering field or
    iron moving with the sensor leaves them unrelated to the turn.
    """
    h = g.hist
    n = g.hist_n
    size = len(h) // 5           # gates.HIST (gates.py imports this module)
    first = (g.hist_i - n) % size
    prev_i = -2
    prev_r = 0.0
    pairs = 0
    s = ss = s1 = dd = 0.0
    t = tt = st = 0.0    # the squared turn t of each pair, and its products with the pair's residual
    pj = 0
    for k in range(n):
        j = ((first + k) % size) * 5
        r = cal.magnitude(h[j], h[j + 1], h[j + 2]) - cal.field
        i = h[j + 3]
        if i == prev_i + 1:
            pairs += 1
            s += r + prev_r
            ss += r * r + prev_r * prev_r
            s1 += r * prev_r
            dd += (r - prev_r) * (r - prev_r)
            # in floats: the codes' squares would be big integers (or overflow) on a board
            x0, y0, z0 = float(h[j]), float(h[j + 1]), float(h[j + 2])
            dx, dy, dz = x0 - h[pj], y0 - h[pj + 1], z0 - h[pj + 2]
            turn = (dx * dx + dy * dy + dz * dz) / (x0 * x0 + y0 * y0 + z0 * z0 or 1.0)
            t += turn
            tt += turn * turn
            st += turn * (r + prev_r)
        prev_i = i
        prev_r = r
        pj = j
    if pairs < _MIN_PAIRS:
        return None, pairs, None, None, None
    white = math.sqrt(dd / (2 * pairs))   # von Neumann: sees the white part only
    m = s / (2 * pairs)
    var = ss / (2 * pairs) - m * m
    if not var > 0.0:
        return None, pairs, None, white, None
    # the pair's mean residual (its variance ~ var) against its turn
    tm = t / pairs
    tvar = tt / pairs - tm * tm
    turn_sd = math.sqrt(tvar) if tvar > 0.0 else 0.0   # of (w T)^2, rad^2: the tau term (session.py _widen)
    rate = (st / (2 * pairs) - m * tm) / math.sqrt(var * tvar) if tvar > 0.0 else None
    return (s1 / pairs - m * m) / var, pairs, rate, white, turn_sd
