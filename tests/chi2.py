"""The chi-squared distribution, central and noncentral, for tests that put a likelihood-ratio
test's decision near its threshold (numpy has draws, not the CDF; scipy is not a dependency).

    chi2_cdf(x, k)                 # P(X <= x), X ~ chi^2 with k degrees of freedom
    ncchi2_cdf(x, k, lam)          # the same with noncentrality lam (a real effect)
"""

import math


def chi2_cdf(x, k):
    """Regularised lower incomplete gamma P(k/2, x/2), by its power series (converges for any x)."""
    if x <= 0:
        return 0.0
    a, z = 0.5 * k, 0.5 * x
    term = 1.0 / a
    total = term
    n = 0
    while term > 1e-17 * total:
        n += 1
        term *= z / (a + n)
        total += term
    return min(1.0, math.exp(a * math.log(z) - z - math.lgamma(a)) * total)


def ncchi2_cdf(x, k, lam):
    """Noncentral chi^2: a Poisson(lam / 2) mixture of central chi^2 with k + 2j degrees of freedom."""
    total = 0.0
    weight = math.exp(-0.5 * lam)
    j = 0
    while j < 10 + lam:
        total += weight * chi2_cdf(x, k + 2 * j)
        j += 1
        weight *= 0.5 * lam / j
    return total
