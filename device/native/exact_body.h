// exact_body.h, for linalgc.c: the solver's exact integer work on a board, shared/moments.py's
// recentred (the power sums re-centred by a Taylor shift along each axis's chains) and
// shared/quadric.py's Problem.exact (g_A, T and the RSS from the sums), in fixed-width two's
// complement words instead of Python ints. In bytecode each of the ~300 big-integer products and
// sums of a trial state is a heap allocation: 7.6 ms of a Pico's solve a state, 16 KB of garbage.
//
// Exact, not approximate: every operation is a ring operation modulo 2**(32 EW) (products,
// sums, shifts left), so each result is the true integer modulo 2**(32 EW) whatever the
// intermediate values did, and it IS the true integer when its magnitude is below 2**EBITS. Each
// kernel first bounds the bits of everything it returns (below) and declines (None: the Python
// runs) where a bound reaches EBITS; inputs past EBITS bits are declined when read.

#include "wide.h"            // mul32: 32 x 32 -> 64 bits where the Cortex-M0+ lacks it
#include "py/smallint.h"    // a small int's range (word_float)

#define EW (16)                 // 32-bit words of an exact number: 512 bits
#define EBITS (500)             // results and inputs held only below 2**EBITS in magnitude
#define ECOUNT (35)             // the power sums (shared/moments.py COUNT)

static inline bool e_negative(const uint32_t *x) { return x[EW - 1] >> 31; }

// out = |x| (out may be x)
// out = -x where negate (complemented, plus one), else x (out may be x)
static void e_negated(uint32_t *out, const uint32_t *x, bool negate) {
    uint32_t flip = negate ? 0xffffffff : 0;
    uint64_t c = flip & 1;
    for (size_t i = 0; i < EW; i++) {
        c += x[i] ^ flip;
        out[i] = (uint32_t)c;
        c >>= 32;
    }
}

static void e_abs(uint32_t *out, const uint32_t *x) {
    e_negated(out, x, e_negative(x));
}

// the number of bits of |x| (moments.bit_length)
static mp_int_t e_bits(const uint32_t *x) {
    uint32_t m[EW];
    e_abs(m, x);
    for (size_t i = EW; i-- > 0;) {
        if (m[i]) {
            mp_int_t n = 32 * i;
            for (uint32_t u = m[i]; u; u >>= 1) {
                n++;
            }
            return n;
        }
    }
    return 0;
}

// Each operation below works modulo 2**(32 n) on the low n words (n <= EW): the kernels take the
// fewest words their bounds allow (a trial state's sums ~170 bits: 6 words), then sign-extend.

// acc += p, or acc -= p (adding its complement plus one)
static void e_add(uint32_t *acc, const uint32_t *p, bool subtract, size_t n) {
    uint32_t flip = subtract ? 0xffffffff : 0;
    uint64_t c = flip & 1;
    for (size_t i = 0; i < n; i++) {
        c += (uint64_t)acc[i] + (p[i] ^ flip);
        acc[i] = (uint32_t)c;
        c >>= 32;
    }
}

// acc += m x, or acc -= m x, for a magnitude m = m[0] + 2**32 m[1]
static void e_add_product(uint32_t *acc, const uint32_t *x, const uint32_t *m, bool subtract, size_t n) {
    uint32_t p[EW];
    uint64_t c = 0;
    for (size_t i = 0; i < n; i++) {
        c += mul32(x[i], m[0]);
        p[i] = (uint32_t)c;
        c >>= 32;
    }
    if (m[1]) {
        c = 0;
        for (size_t i = 0; i + 1 < n; i++) {         // (2**32-1)**2 + 2 (2**32-1) < 2**64: no carry lost
            c += mul32(x[i], m[1]) + p[i + 1];
            p[i + 1] = (uint32_t)c;
            c >>= 32;
        }
    }
    e_add(acc, p, subtract, n);
}

// acc += x << shift, or acc -= x << shift
static void e_add_shifted(uint32_t *acc, const uint32_t *x, size_t shift, bool subtract, size_t n) {
    uint32_t p[EW];
    size_t w = shift / 32, b = shift % 32;
    for (size_t i = 0; i < n; i++) {
        uint32_t hi = i >= w ? x[i - w] : 0, lo = i >= w + 1 ? x[i - w - 1] : 0;
        p[i] = b ? (hi << b) | (lo >> (32 - b)) : hi;
    }
    e_add(acc, p, subtract, n);
}

// words n .. EW-1 of x set to the sign of word n-1
static void e_extend(uint32_t *x, size_t n) {
    uint32_t sign = x[n - 1] >> 31 ? 0xffffffff : 0;
    for (size_t i = n; i < EW; i++) {
        x[i] = sign;
    }
}

// the words that hold a signed number of `bits` bits of magnitude
static inline size_t e_words(mp_int_t bits) {
    return bits / 32 + 1;
}

// out = x >> shift rounded down (a floor, as Python shifts a negative int), all EW words
static inline void e_shift_right(uint32_t *out, const uint32_t *x, size_t shift) {
    uint32_t sign = e_negative(x) ? 0xffffffff : 0;
    size_t w = shift / 32, b = shift % 32;
    for (size_t i = 0; i < EW; i++) {
        uint32_t lo = i + w < EW ? x[i + w] : sign, hi = i + w + 1 < EW ? x[i + w + 1] : sign;
        out[i] = b ? (lo >> b) | (hi << (32 - b)) : lo;
    }
}

// |x| in m[0..1] where it is under 2**64; false if not
static bool e_small(const uint32_t *x, uint32_t *m) {
    uint32_t a[EW];
    e_abs(a, x);
    for (size_t i = 2; i < EW; i++) {
        if (a[i]) {
            return false;
        }
    }
    m[0] = a[0];
    m[1] = a[1];
    return true;
}

static inline mp_int_t e_max(mp_int_t a, mp_int_t b) { return a > b ? a : b; }

// moments._taylor for every axis whose centre moves: s (ECOUNT numbers of EW words) re-centred on
// c (3 numbers) in place, along chains[axis] (moments._CHAINS: each chain its length, then the
// storage indices of m x^0 .. m x^d). Its bound, per sum: M'_t = sum_j C(t, j) (-c)^(t-j) M_j has
// at most 4 + max_j (bits M_j + (t - j) bits c) bits (the binomials' sum 2^t <= 16). False: a bound
// reached EBITS, s untouched.
static bool e_recentre(uint32_t *s, const uint32_t *c, const uint8_t *const *chains, const size_t *ends) {
    mp_int_t bound[ECOUNT];
    for (size_t i = 0; i < ECOUNT; i++) {
        bound[i] = e_bits(s + EW * i);
    }
    uint32_t m[3][2];
    for (size_t axis = 0; axis < 3; axis++) {
        if (!e_small(c + EW * axis, m[axis])) {
            return false;
        }
        mp_int_t cb = e_bits(c + EW * axis);
        const uint8_t *ch = chains[axis];
        for (size_t p = 0; cb && p < ends[axis]; p += ch[p] + 1) {
            for (size_t t = ch[p] - 1; t >= 1; t--) {         // top down: the bounds of the old values
                mp_int_t b = 0;
                for (size_t j = 0; j <= t; j++) {
                    b = e_max(b, bound[ch[p + 1 + j]] + (mp_int_t)(t - j) * cb);
                }
                bound[ch[p + 1 + t]] = b + 4;
                if (b + 4 >= EBITS) {
                    return false;
                }
            }
        }
    }
    mp_int_t most = 0;
    for (size_t i = 0; i < ECOUNT; i++) {
        most = e_max(most, bound[i]);
    }
    size_t n = e_words(most);
    for (size_t axis = 0; axis < 3; axis++) {
        const uint8_t *ch = chains[axis];
        if (!m[axis][0] && !m[axis][1]) {
            continue;
        }
        for (size_t p = 0; p < ends[axis]; p += ch[p] + 1) {
            size_t top = p + ch[p];                              // the chain is ch[p + 1 .. top]
            for (size_t k = p + 2; k <= top; k++) {
                for (size_t e = top - 1; e + 2 > k; e--) {       // s[upper] -= c s[lower], upper from the top
                    e_add_product(s + EW * ch[e + 1], s + EW * ch[e], m[axis], !e_negative(c + EW * axis), n);
                }
            }
        }
    }
    for (size_t i = 0; i < ECOUNT; i++) {
        e_extend(s + EW * i, n);
    }
    return true;
}

// Problem.exact: out[0..5] g_A, out[6..8] T, out[9] the RSS, from the sums s, the fixed-point
// quadric a (6 numbers) and f3 = 3 FRAC; idx: quadric's _IDX4 (36), _IDX3 (18), _IDX2 (6), _IDX1 (3).
// False: an input or a bound past EBITS (each result's: its terms' bits, +3 for up to 8 of them).
static bool e_exact(uint32_t *out, const uint32_t *s, const uint32_t *a, const uint8_t *idx, size_t f3) {
    const uint8_t *idx4 = idx, *idx3 = idx + 36, *idx2 = idx + 54, *idx1 = idx + 60;
    uint32_t ac[6][2], am[6][2], w[EW];
    mp_int_t bs[ECOUNT], ba = 0, bound[10];
    for (size_t k = 0; k < 6; k++) {
        for (size_t i = 0; i < EW; i++) {
            w[i] = 0;
        }
        e_add_shifted(w, a + EW * k, k < 3 ? 0 : 1, false, EW);   // ac_k = W_C[k] a_k
        if (!e_small(w, ac[k]) || !e_small(a + EW * k, am[k])) {
            return false;
        }
        ba = e_max(ba, e_bits(w));
    }
    for (size_t i = 0; i < ECOUNT; i++) {
        bs[i] = e_bits(s + EW * i);
    }
    for (size_t r = 0; r < 10; r++) {
        const uint8_t *row = r < 6 ? idx4 + 6 * r : r < 9 ? idx3 + 6 * (r - 6) : idx2;
        mp_int_t b = r < 6 ? bs[idx2[r]] + f3 : r < 9 ? bs[idx1[r - 6]] + f3 : 0;
        for (size_t k = 0; k < 6; k++) {
            b = e_max(b, ba + bs[row[k]]);
        }
        bound[r] = b + 3 + (r >= 3 && r < 6);                   // (g_A's off-diagonal rows doubled)
    }
    // the RSS: 2^6F n - 2^3F lin + sum_m a_m g_A[m]
    mp_int_t brss = e_max(bs[0] + 2 * f3, bound[9] + f3);
    for (size_t m = 0; m < 6; m++) {
        brss = e_max(brss, e_bits(a + EW * m) + bound[m]);
    }
    for (size_t r = 0; r < 9; r++) {
        brss = e_max(brss, bound[r]);
    }
    if (brss + 3 >= EBITS) {
        return false;
    }
    size_t n = e_words(brss + 3);
    for (size_t r = 0; r < 10; r++) {
        uint32_t *acc = out + EW * r;
        const uint8_t *row = r < 6 ? idx4 + 6 * r : r < 9 ? idx3 + 6 * (r - 6) : idx2;
        for (size_t i = 0; i < EW; i++) {
            acc[i] = 0;
        }
        for (size_t k = 0; k < 6; k++) {
            e_add_product(acc, s + EW * row[k], ac[k], e_negative(a + EW * k), n);
        }
        if (r < 9) {
            e_add_shifted(acc, s + EW * (r < 6 ? idx2[r] : idx1[r - 6]), f3, true, n);
        }
        if (r >= 3 && r < 6) {
            for (size_t i = 0; i < EW; i++) {
                w[i] = acc[i];
                acc[i] = 0;
            }
            e_add_shifted(acc, w, 1, false, n);
        }
        e_extend(acc, n);
    }
    // lin (out[9]) -> rss in w
    for (size_t i = 0; i < EW; i++) {
        w[i] = 0;
    }
    e_add_shifted(w, s, 2 * f3, false, n);
    e_add_shifted(w, out + EW * 9, f3, true, n);
    for (size_t m = 0; m < 6; m++) {
        e_add_product(w, out + EW * m, am[m], e_negative(a + EW * m), n);
    }
    e_extend(w, n);
    for (size_t i = 0; i < EW; i++) {
        out[EW * 9 + i] = w[i];
    }
    return true;
}
