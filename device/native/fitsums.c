// fitsums: the 34 power sums x^i y^j z^k (1 <= i+j+k <= 4) of shared.fit.EllipsoidFit,
// summed in machine words (a MicroPython native module, .mpy).
//
//     import fitsums
//     class Fit:
//         add = fitsums.add            # a method: add(self, x, y, z, out=False)
//     fit._words = array.array("i", [0] * fitsums.WORDS)
//     fit._words[fitsums.LEFT] = samples the words may take before draining
//
// Each sum is a 128-bit two's-complement integer in four 32-bit words, least
// significant first, at _words[4*(n-1) .. 4*n-1] for storage index n (shared.moments.ORDER);
// _words[COUNT] is the net count of samples added (index 0's share, signed), and
// _words[LEFT] counts down the samples before the words must be drained. Sums are exact
// modulo 2^128, so exact while the true sum fits in 127 bits and a sign: with |v| < 2^24
// each monomial is under 2^96 in magnitude, and shared.fit drains the words into its
// Python integers before 2^24 samples (2^24 * 2^96 = 2^120).
//
// A code that is not a small int, or whose magnitude is 2^24 or more, and a sample that
// finds LEFT at 0, go to self._add_slow(x, y, z, out) (pure Python: it drains, and sums
// any int exactly, or refuses a float). MicroPython's small ints have the same tag on
// every object representation, so one build serves an architecture.
//
//     fitsums.magnitude(numbers, sx, sy, sz)    # shared.fixedpoint.ExactCorrection's |h_c|, or None
//
// is the survey's exact |h_c| (below, beside magnitude()).

#include "py/dynruntime.h"

#define SUMS (34)
#define COUNT (4 * SUMS)
#define LEFT (COUNT + 1)
#define WORDS (COUNT + 2)
#define LIMIT (1 << 24)

// the factors F = [x, y, z, xx, xy, xz, yy, yz, zz] (indices 0..8) of the degree-3 and -4
// sums in storage order (shared.moments.ORDER): degree 3 = (degree 2) * v, 4 = (2) * (2)
static const uint8_t FACTORS[25][2] = {
    {3, 0}, {3, 1}, {3, 2}, {6, 0}, {4, 2}, {8, 0},                      // xxx xxy xxz xyy xyz xzz
    {6, 1}, {6, 2}, {8, 1}, {8, 2},                                      // yyy yyz yzz zzz
    {3, 3}, {3, 4}, {3, 5}, {3, 6}, {3, 7}, {3, 8},                      // x^4 x3y x3z x2y2 x2yz x2z2
    {4, 6}, {4, 7}, {4, 8}, {5, 8},                                      // xy3 xy2z xyz2 xz3
    {6, 6}, {6, 7}, {6, 8}, {7, 8}, {8, 8},                              // y^4 y3z y2z2 yz3 z^4
};

// a * b in 64 bits: the Cortex-M0+ multiplies 32 x 32 -> 32 only, and libgcc's
// 64-bit multiply is not linked into a native module, so 16-bit products there
static inline uint64_t mul32(uint32_t a, uint32_t b) {
    #if defined(__ARM_ARCH_6M__)
    uint32_t al = a & 0xffff, ah = a >> 16, bl = b & 0xffff, bh = b >> 16;
    uint64_t mid = (uint64_t)(al * bh) + (ah * bl);
    return ((uint64_t)(ah * bh) << 32) + (mid << 16) + al * bl;
    #else
    return (uint64_t)a * b;
    #endif
}

// a * b for b < 2^16
static inline uint64_t mul32x16(uint32_t a, uint32_t b) {
    #if defined(__ARM_ARCH_6M__)
    return ((uint64_t)((a >> 16) * b) << 16) + (a & 0xffff) * b;
    #else
    return (uint64_t)a * b;
    #endif
}

// acc += m (or -= when negate), m = m0 + 2^32 m1 + 2^64 m2 a magnitude; subtracting is
// adding the complement plus one (~m + 1 = -m), carried through the four words
static inline void accumulate(uint32_t *acc, uint32_t m0, uint32_t m1, uint32_t m2, bool negate) {
    uint32_t flip = negate ? 0xffffffff : 0;
    #if defined(__ARM_ARCH_6M__)
    // Thumb-1 has add-with-carry, which C cannot ask for: one ADCS chain for the (complemented)
    // magnitude, a second for the complement's +1
    uint32_t a0 = acc[0], a1 = acc[1], a2 = acc[2], a3 = acc[3];
    uint32_t w0 = m0 ^ flip, w1 = m1 ^ flip, w2 = m2 ^ flip;
    __asm__ (".syntax unified\n\t"      // gcc's Thumb-1 default is the older, divided syntax
             "adds %[a0], %[a0], %[w0]\n\t"
             "adcs %[a1], %[w1]\n\t"
             "adcs %[a2], %[w2]\n\t"
             "adcs %[a3], %[flip]\n\t"
             "movs %[w0], #1\n\t"
             "ands %[w0], %[flip]\n\t"
             "movs %[w1], #0\n\t"
             "adds %[a0], %[a0], %[w0]\n\t"
             "adcs %[a1], %[w1]\n\t"
             "adcs %[a2], %[w1]\n\t"
             "adcs %[a3], %[w1]\n\t"
             ".syntax divided"
             : [a0] "+l"(a0), [a1] "+l"(a1), [a2] "+l"(a2), [a3] "+l"(a3), [w0] "+l"(w0), [w1] "+l"(w1)
             : [w2] "l"(w2), [flip] "l"(flip)
             : "cc");
    acc[0] = a0;
    acc[1] = a1;
    acc[2] = a2;
    acc[3] = a3;
    #else
    uint64_t c = (uint64_t)acc[0] + (m0 ^ flip) + (negate ? 1 : 0);
    acc[0] = (uint32_t)c;
    c = (c >> 32) + acc[1] + (m1 ^ flip);
    acc[1] = (uint32_t)c;
    c = (c >> 32) + acc[2] + (m2 ^ flip);
    acc[2] = (uint32_t)c;
    acc[3] += (uint32_t)(c >> 32) + flip;
    #endif
}

// a small int with |v| < limit, in *v; false for anything else (a code, a magnitude's sum)
static bool small_within(mp_obj_t o, int64_t limit, int64_t *v) {
    if (!mp_obj_is_small_int(o)) {
        return false;
    }
    int64_t n = MP_OBJ_SMALL_INT_VALUE(o);
    if (n <= -limit || n >= limit) {
        return false;
    }
    *v = n;
    return true;
}

// a small int with |v| < LIMIT: its magnitude and sign; false for anything else
static bool small_code(mp_obj_t o, uint64_t *mag, bool *neg) {
    int64_t n;
    if (!small_within(o, LIMIT, &n)) {
        return false;
    }
    *neg = n < 0;
    *mag = (uint64_t)(n < 0 ? -n : n);
    return true;
}

// add(self, x, y, z[, out]): the sample's 34 monomials added to (out: subtracted from) self._words
static mp_obj_t add(size_t n_args, const mp_obj_t *args) {
    mp_obj_t out = n_args > 4 ? args[4] : mp_const_false;
    mp_buffer_info_t bufinfo;
    mp_get_buffer_raise(mp_load_attr(args[0], MP_QSTR__words), &bufinfo, MP_BUFFER_RW);
    if (bufinfo.len < WORDS * sizeof(uint32_t)) {
        mp_raise_ValueError(MP_ERROR_TEXT("fitsums: _words holds fewer than WORDS words"));
    }
    int32_t *words = (int32_t *)bufinfo.buf;
    // magnitudes (under 2^24, then 2^48) and signs of F = [x, y, z, xx, xy, xz, yy, yz, zz]
    uint64_t m[9];
    bool s[9];
    if (words[LEFT] <= 0 || !small_code(args[1], &m[0], &s[0]) || !small_code(args[2], &m[1], &s[1]) ||
        !small_code(args[3], &m[2], &s[2])) {
        mp_obj_t call[4] = {args[1], args[2], args[3], out};
        return mp_call_function_n_kw(mp_load_attr(args[0], MP_QSTR__add_slow), 4, 0, call);
    }
    static const uint8_t SQUARES[6][2] = {{0, 0}, {0, 1}, {0, 2}, {1, 1}, {1, 2}, {2, 2}};
    for (int k = 0; k < 6; k++) {
        int i = SQUARES[k][0], j = SQUARES[k][1];
        m[3 + k] = mul32((uint32_t)m[i], (uint32_t)m[j]);
        s[3 + k] = s[i] != s[j];
    }
    bool negate = mp_obj_is_true(out);
    words[LEFT] -= 1;
    words[COUNT] += negate ? -1 : 1;
    uint32_t *acc = (uint32_t *)words;
    // degrees 1 and 2: the factors themselves
    for (int k = 0; k < 9; k++, acc += 4) {
        accumulate(acc, (uint32_t)m[k], (uint32_t)(m[k] >> 32), 0, s[k] != negate);
    }
    // degrees 3 and 4: a * b with a < 2^48, b < 2^48, column by column in 32-bit words
    for (int k = 0; k < 25; k++, acc += 4) {
        int i = FACTORS[k][0], j = FACTORS[k][1];
        uint32_t a0 = (uint32_t)m[i], a1 = (uint32_t)(m[i] >> 32), b0 = (uint32_t)m[j], b1 = (uint32_t)(m[j] >> 32);
        uint64_t t = mul32(a0, b0);
        uint32_t p0 = (uint32_t)t;
        uint64_t mid = (t >> 32) + mul32x16(a0, b1) + mul32x16(b0, a1);     // under 2^50
        uint32_t p1 = (uint32_t)mid;
        uint32_t p2 = (uint32_t)(mid >> 32) + a1 * b1;                       // the product is under 2^96
        accumulate(acc, p0, p1, p2, (s[i] != s[j]) != negate);
    }
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(add_obj, 4, 5, add);

// ****** magnitude: shared.fixedpoint.ExactCorrection.magnitude in machine words ******
//
// h_i = floor((c_i0 e_0 + c_i1 e_1 + c_i2 e_2 - k_i) / 2^d), e_j = s_j - w_j, and
// floor(sqrt(h_0^2 + h_1^2 + h_2^2)): the same integer as the pure-Python method.
// `numbers` is a buffer of NUMBERS x 4 uint16 limbs (an array("H")), each number's 64-bit
// two's complement least significant limb first, in ExactCorrection._flat's order:
// w0..w2, c00..c22, k0..k2, d. Widths, and why they hold:
// - e_j: a sum s_j must be a small int with |s_j| < 2^31 (checked per call, else None);
//   shared.fixedpoint admits |w_j| < 2^31 once, at construction, so |e_j| < 2^32: one word.
//   The survey's sums are of at most 2^23-code magnitudes times its window (2^29 at 64).
// - c_ij, k_i: |c|, |k| < 2^63 (admitted at construction): two words. The coefficients are
//   M (nT a code) x 1000 x 2^_COEF_BITS (36) / n: about 2^40 / n at 0.0144 nT a code (|k| is
//   at most 1.5 of the largest), big ints on a 32-bit port, so they reach C as limbs.
// - the dot product: 3 x 2^63 x 2^32 + 2^63 < 2^97, exact in a 128-bit two's complement
//   (four words, `accumulate` above); 0 < d < 32 (28: _COEF_BITS - FRACTION_BITS).
// - h_i must satisfy |h_i| < 2^62 (else None): h_i^2 < 2^124, the sum of three < 2^126,
//   its root < 2^63. |h_c| in 1/256 milli-nT is about 2^34 at 50,000 nT, so never near.
// - the root is exact, digit by digit (no multiply, no divide: neither 64-bit division nor,
//   on armv6m, 64-bit multiplication is linked into a native module).
// The result is a small int where it fits, else built from its words (mp_binary_op: on a
// 32-bit port |h_c| of the Earth's field passes a small int's 2^30).

#define NUMBERS (16)
#define SUM_LIMIT ((int64_t)1 << 31)
#define H_LIMIT ((uint64_t)1 << 62)

// the number at limbs p[0..3]: a 64-bit two's complement
static inline int64_t number(const uint16_t *p) {
    uint32_t lo = p[0] | ((uint32_t)p[1] << 16), hi = p[2] | ((uint32_t)p[3] << 16);
    return (int64_t)(((uint64_t)hi << 32) | lo);
}

// a small int with |s| < SUM_LIMIT, false for anything else
static bool small_sum(mp_obj_t o, int64_t *v) {
    return small_within(o, SUM_LIMIT, v);
}

// q += v 2^(32 k) in an unsigned four-word sum (k <= 2; the sum stays under 2^126)
static inline void add_at(uint32_t *q, uint64_t v, int k) {
    uint64_t c = (uint64_t)q[k] + (uint32_t)v;
    q[k] = (uint32_t)c;
    c = (c >> 32) + q[k + 1] + (v >> 32);
    q[k + 1] = (uint32_t)c;
    for (k += 2; k < 4; k++) {
        c = (c >> 32) + q[k];
        q[k] = (uint32_t)c;
    }
}

// floor(sqrt(q)) of q = qh 2^64 + ql < 2^126, digit by digit: `bit` walks the powers of 4
// down from the largest <= q; `res` gathers the root shifted up by bit's position, so that
// q - (root so far)^2 >= res + bit decides the next bit of the root (Crandall & Pomerance's
// bitwise root; only adds, subtracts and constant shifts)
static uint64_t isqrt128(uint64_t qh, uint64_t ql) {
    uint64_t bh = (uint64_t)1 << 60, bl = 0;                 // 4^62 = 2^124
    while ((bh | bl) && (bh > qh || (bh == qh && bl > ql))) {
        bl = (bl >> 2) | (bh << 62);
        bh >>= 2;
    }
    uint64_t rh = 0, rl = 0;
    while (bh | bl) {
        uint64_t tl = rl + bl;
        uint64_t th = rh + bh + (tl < rl);
        // res >>= 1 either way; + bit where q >= res + bit (then q -= res + bit)
        bool take = th < qh || (th == qh && tl <= ql);
        rl = (rl >> 1) | (rh << 63);
        rh >>= 1;
        if (take) {
            qh -= th + (ql < tl);
            ql -= tl;
            rl += bl;
            rh += bh + (rl < bl);
        }
        bl = (bl >> 2) | (bh << 62);
        bh >>= 2;
    }
    return rl;      // the root < 2^63: rh is 0
}

// an int object of r < 2^64: a small int (at least 31 bits signed on every port; from a
// machine word, mp_obj_new_int_from_uint makes one where it fits), or a long int from the words
static mp_obj_t new_uint64(uint64_t r) {
    if (r < ((uint64_t)1 << 30)) {
        return MP_OBJ_NEW_SMALL_INT((mp_int_t)r);
    }
    if (sizeof(mp_uint_t) >= sizeof(uint64_t) || r >> 32 == 0) {
        return mp_obj_new_int_from_uint((mp_uint_t)r);
    }
    mp_obj_t hi = mp_obj_new_int_from_uint((mp_uint_t)(uint32_t)(r >> 32));
    hi = mp_binary_op(MP_BINARY_OP_LSHIFT, hi, MP_OBJ_NEW_SMALL_INT(32));
    return mp_binary_op(MP_BINARY_OP_OR, hi, mp_obj_new_int_from_uint((mp_uint_t)(uint32_t)r));
}

// magnitude(numbers, sx, sy, sz): |h_c| as ExactCorrection.magnitude computes it, or None where
// a sum or an h_i is past the widths above (the caller then runs the pure-Python method)
static mp_obj_t magnitude(size_t n_args, const mp_obj_t *args) {
    mp_buffer_info_t bufinfo;
    mp_get_buffer_raise(args[0], &bufinfo, MP_BUFFER_READ);
    if (bufinfo.len < 4 * NUMBERS * sizeof(uint16_t)) {
        mp_raise_ValueError(MP_ERROR_TEXT("fitsums: numbers holds fewer than 4 NUMBERS limbs"));
    }
    const uint16_t *num = (const uint16_t *)bufinfo.buf;
    uint32_t me[3];             // |e_j| < 2^32
    bool se[3];
    for (int j = 0; j < 3; j++) {
        int64_t s;
        if (!small_sum(args[1 + j], &s)) {
            return mp_const_none;
        }
        int64_t e = s - number(num + 4 * j);
        se[j] = e < 0;
        me[j] = (uint32_t)(uint64_t)(e < 0 ? -e : e);
    }
    uint32_t d = (uint32_t)number(num + 4 * 15);
    if (d == 0 || d >= 32) {
        return mp_const_none;
    }
    uint32_t q[4];                      // h_0^2 + h_1^2 + h_2^2, unsigned (no initialiser: memset is not linked)
    q[0] = q[1] = q[2] = q[3] = 0;
    for (int i = 0; i < 3; i++) {
        uint32_t acc[4];
        acc[0] = acc[1] = acc[2] = acc[3] = 0;
        for (int j = 0; j < 3; j++) {
            int64_t c = number(num + 4 * (3 + 3 * i + j));
            uint64_t mc = (uint64_t)(c < 0 ? -c : c);       // < 2^63
            // |c| |e| = lo + hi 2^32 < 2^95: three words
            uint64_t lo = mul32((uint32_t)mc, me[j]), hi = mul32((uint32_t)(mc >> 32), me[j]);
            uint64_t t = (lo >> 32) + (uint32_t)hi;
            accumulate(acc, (uint32_t)lo, (uint32_t)t, (uint32_t)((t >> 32) + (hi >> 32)), (c < 0) != se[j]);
        }
        int64_t k = number(num + 4 * (12 + i));
        uint64_t mk = (uint64_t)(k < 0 ? -k : k);
        accumulate(acc, (uint32_t)mk, (uint32_t)(mk >> 32), 0, k >= 0);        // - k
        // h = acc >> d, arithmetic (floor), 0 < d < 32
        uint32_t h0 = (acc[0] >> d) | (acc[1] << (32 - d)), h1 = (acc[1] >> d) | (acc[2] << (32 - d));
        uint32_t h2 = (acc[2] >> d) | (acc[3] << (32 - d)), h3 = (uint32_t)((int32_t)acc[3] >> d);
        uint32_t sign = (uint32_t)((int32_t)h1 >> 31);
        if (h2 != sign || h3 != sign) {
            return mp_const_none;
        }
        int64_t h = (int64_t)(((uint64_t)h1 << 32) | h0);
        uint64_t mh = (uint64_t)(h < 0 ? -h : h);
        if (mh >= H_LIMIT) {
            return mp_const_none;
        }
        // h^2 = m0^2 + 2 m0 m1 2^32 + m1^2 2^64, m1 < 2^30
        uint32_t m0 = (uint32_t)mh, m1 = (uint32_t)(mh >> 32);
        uint64_t x = mul32(m0, m1);
        add_at(q, mul32(m0, m0), 0);
        add_at(q, x, 1);
        add_at(q, x, 1);
        add_at(q, mul32(m1, m1), 2);
    }
    return new_uint64(isqrt128(((uint64_t)q[3] << 32) | q[2], ((uint64_t)q[1] << 32) | q[0]));
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(magnitude_obj, 4, 4, magnitude);

mp_obj_t mpy_init(mp_obj_fun_bc_t *self, size_t n_args, size_t n_kw, mp_obj_t *args) {
    MP_DYNRUNTIME_INIT_ENTRY
    mp_store_global(MP_QSTR_add, MP_OBJ_FROM_PTR(&add_obj));
    mp_store_global(MP_QSTR_magnitude, MP_OBJ_FROM_PTR(&magnitude_obj));
    mp_store_global(MP_QSTR_NUMBERS, MP_OBJ_NEW_SMALL_INT(NUMBERS));
    mp_store_global(MP_QSTR_WORDS, MP_OBJ_NEW_SMALL_INT(WORDS));
    mp_store_global(MP_QSTR_COUNT, MP_OBJ_NEW_SMALL_INT(COUNT));
    mp_store_global(MP_QSTR_LEFT, MP_OBJ_NEW_SMALL_INT(LEFT));
    MP_DYNRUNTIME_INIT_EXIT
}
