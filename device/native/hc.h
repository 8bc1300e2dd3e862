// hc.h: the survey's exact |h_c| (shared.fixedpoint.ExactCorrection) in machine words, for
// fitsums.c (which it is included into, after wide.h), and gatesc.c, which defines HC_ONLY: hc()
// alone, for the disturbance gate (none of the functions below that take Python arguments):
//
//     magnitude(numbers, sx, sy, sz)        # ExactCorrection.magnitude's |h_c|, or None
//     survey(words, sx, sy, sz, st)         # device/survey.py Survey.sample's sums, |h_c| with them
//     correct(numbers, sx, sy, sz)          # ExactCorrection.correct's h_c (a tuple), or None
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
//   on armv6m, 64-bit multiplication is linked into a native module); its first 29 bits in
//   32-bit words, the rest in one 64-bit remainder where the sum of squares is under 2^120
//   (always, for a field), else in 128-bit words.
// magnitude's result is a small int where it fits, else built from its words (mp_binary_op:
// on a 32-bit port |h_c| of the Earth's field passes a small int's 2^30): four heap
// allocations a call, which survey() spares the per-sample path (its sums stay in words).

#define NUMBERS (16)
#define SUM_LIMIT ((int64_t)1 << 31)
#define H_LIMIT ((uint64_t)1 << 62)

// the number at limbs p[0..3]: a 64-bit two's complement
static inline int64_t number(const uint16_t *p) {
    uint32_t lo = p[0] | ((uint32_t)p[1] << 16), hi = p[2] | ((uint32_t)p[3] << 16);
    return (int64_t)(((uint64_t)hi << 32) | lo);
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

#ifndef HC_ONLY
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
#endif

// floor(sqrt(q)) of q (four words) < 2^120, two bits of q at a time from the top: rem = (q's
// bits so far) - root^2 <= 2 root, so with root < 2^60 rem << 2 stays under 2^63 and the
// trial 2 root + 1 under 2^62: one 64-bit word each (the classic schoolbook root)
static uint64_t isqrt120(const uint32_t *q) {
    int w = 3;
    while (w > 0 && q[w] == 0) {
        w--;
    }
    int s = 30;
    while (s > 0 && (q[w] >> s) == 0) {     // the top word's leading zero pairs
        s -= 2;
    }
    // the root's first 29 bits in single words: while root < 2^28, rem <= 2 root < 2^29 and
    // rem << 2 | 3 < 2^31 (a 32-bit iteration is a fifth of a 64-bit one on a Cortex-M0+)
    uint32_t root32 = 0, rem32 = 0;
    for (; w >= 0; w--, s = 30) {
        uint32_t word = q[w];
        for (; s >= 0; s -= 2) {
            if (root32 >> 28) {
                goto wide;
            }
            rem32 = (rem32 << 2) | ((word >> s) & 3);
            root32 <<= 1;
            uint32_t trial = (root32 << 1) | 1;
            if (rem32 >= trial) {
                rem32 -= trial;
                root32 |= 1;
            }
        }
    }
    return root32;
wide:;
    uint64_t root = root32, rem = rem32;
    for (; w >= 0; w--, s = 30) {
        uint32_t word = q[w];
        for (; s >= 0; s -= 2) {
            rem = (rem << 2) | ((word >> s) & 3);
            root <<= 1;
            uint64_t trial = (root << 1) | 1;
            if (rem >= trial) {
                rem -= trial;
                root |= 1;
            }
        }
    }
    return root;
}

// h_c's axes h[i] = floor((sum_j c_ij e_j - k_i) / 2^d), e_j = s[j] - w_j, each with
// |h_i| < 2^62 checked (false: past the words, or d out of 0 < d < 32)
static bool axes(const uint16_t *num, const int64_t *s, int64_t *h) {
    uint32_t me[3];             // |e_j| < 2^32
    bool se[3];
    for (int j = 0; j < 3; j++) {
        int64_t e = s[j] - number(num + 4 * j);
        se[j] = e < 0;
        me[j] = (uint32_t)(uint64_t)(e < 0 ? -e : e);
    }
    uint32_t d = (uint32_t)number(num + 4 * 15);
    if (d == 0 || d >= 32) {
        return false;
    }
    for (int i = 0; i < 3; i++) {
        uint32_t acc[4];
        acc[0] = acc[1] = acc[2] = acc[3] = 0;      // (no initialiser: memset is not linked)
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
            return false;
        }
        h[i] = (int64_t)(((uint64_t)h1 << 32) | h0);
        if ((uint64_t)(h[i] < 0 ? -h[i] : h[i]) >= H_LIMIT) {
            return false;
        }
    }
    return true;
}

// |h_c| of the sums s[0..2] in *f (false: past the words, as axes())
static bool hc(const uint16_t *num, const int64_t *s, uint64_t *f) {
    int64_t h[3];
    if (!axes(num, s, h)) {
        return false;
    }
    uint32_t q[4];                      // h_0^2 + h_1^2 + h_2^2, unsigned
    q[0] = q[1] = q[2] = q[3] = 0;
    for (int i = 0; i < 3; i++) {
        uint64_t mh = (uint64_t)(h[i] < 0 ? -h[i] : h[i]);
        // h^2 = a + 2 b 2^32 + c 2^64: a = m0^2, b = m0 m1 < 2^62, c = m1^2 < 2^60 (m1 < 2^30),
        // its four words added to q with one carry chain
        uint32_t m0 = (uint32_t)mh, m1 = (uint32_t)(mh >> 32);
        uint64_t a = mul32(m0, m0), b2 = mul32(m0, m1) << 1, c = mul32(m1, m1);
        uint64_t t = (a >> 32) + (uint32_t)b2;
        uint32_t w1 = (uint32_t)t;
        t = (t >> 32) + (b2 >> 32) + (uint32_t)c;
        uint32_t w2 = (uint32_t)t, w3 = (uint32_t)(t >> 32) + (uint32_t)(c >> 32);
        t = (uint64_t)q[0] + (uint32_t)a;
        q[0] = (uint32_t)t;
        t = (t >> 32) + q[1] + w1;
        q[1] = (uint32_t)t;
        t = (t >> 32) + q[2] + w2;
        q[2] = (uint32_t)t;
        q[3] += (uint32_t)(t >> 32) + w3;
    }
    if (q[3] < ((uint32_t)1 << 24)) {
        *f = isqrt120(q);
    } else {
        *f = isqrt128(((uint64_t)q[3] << 32) | q[2], ((uint64_t)q[1] << 32) | q[0]);
    }
    return true;
}

#ifndef HC_ONLY
// the numbers' limbs (an array("H") of 4 NUMBERS)
static const uint16_t *limbs(mp_obj_t numbers) {
    mp_buffer_info_t bufinfo;
    mp_get_buffer_raise(numbers, &bufinfo, MP_BUFFER_READ);
    if (bufinfo.len < 4 * NUMBERS * sizeof(uint16_t)) {
        mp_raise_ValueError(MP_ERROR_TEXT("fitsums: numbers holds fewer than 4 NUMBERS limbs"));
    }
    return (const uint16_t *)bufinfo.buf;
}

// the n sums at args[0..n-1], each a small int with |s| < SUM_LIMIT (false for anything else)
static bool sums(const mp_obj_t *args, int n, int64_t *s) {
    for (int j = 0; j < n; j++) {
        if (!small_within(args[j], SUM_LIMIT, &s[j])) {
            return false;
        }
    }
    return true;
}

// magnitude(numbers, sx, sy, sz): |h_c| as ExactCorrection.magnitude computes it, or None where
// a sum or an h_i is past the widths above (the caller then runs the pure-Python method)
static mp_obj_t magnitude(size_t n_args, const mp_obj_t *args) {
    const uint16_t *num = limbs(args[0]);
    int64_t s[3];
    uint64_t f;
    if (!sums(args + 1, 3, s) || !hc(num, s, &f)) {
        return mp_const_none;
    }
    return new_uint64(f);
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(magnitude_obj, 4, 4, magnitude);

// ****** survey: device/survey.py Survey.sample with |h_c|, in words ******
//
// words, an array("H") of SURVEY_LIMBS 16-bit limbs: the open block's sums of x, y, z, t and
// |h_c|, each a 64-bit two's complement in four limbs (least significant first; read as 32-bit
// words: the targets are little-endian), then LEFT: the samples the block still takes, HAS_F:
// 1 where |h_c| is summed with the numbers at NUMBERS_AT (magnitude()'s), 0 where it is 0 (as
// Survey.sample's f when no block goes out). One buffer, so the call takes five arguments:
// device/survey.py's Output.sample stays within the frame MicroPython keeps off the heap. A
// sample adds |s| < 2^31 each and |h_c| < F_LIMIT (2^47: 5.5e8 nT in 1/256 milli-nT), and
// blocks are under 2^16 samples (LEFT is one limb): every sum stays under 2^63.

#define SURVEY_LEFT (20)
#define SURVEY_HAS_F (21)
#define NUMBERS_AT (22)
#define SURVEY_LIMBS (NUMBERS_AT + 4 * NUMBERS)
#define F_LIMIT ((uint64_t)1 << 47)

static inline void add64(uint32_t *w, uint64_t v) {
    uint64_t a = (((uint64_t)w[1] << 32) | w[0]) + v;
    w[0] = (uint32_t)a;
    w[1] = (uint32_t)(a >> 32);
}

// survey(words, sx, sy, sz, st): the sample into the open block; True when it completes the
// block, False if not, None where a sum, h_i or |h_c| is past the words or LEFT is 0: then
// nothing changed (the caller runs the pure-Python way)
static mp_obj_t survey(size_t n_args, const mp_obj_t *args) {
    mp_buffer_info_t bufinfo;
    mp_get_buffer_raise(args[0], &bufinfo, MP_BUFFER_RW);
    if (bufinfo.len < SURVEY_LIMBS * sizeof(uint16_t)) {
        mp_raise_ValueError(MP_ERROR_TEXT("fitsums: words holds fewer than SURVEY_LIMBS limbs"));
    }
    uint16_t *limb = (uint16_t *)bufinfo.buf;
    int64_t s[4];
    uint64_t f = 0;
    if (limb[SURVEY_LEFT] == 0 || !sums(args + 1, 4, s)) {
        return mp_const_none;
    }
    if (limb[SURVEY_HAS_F] && (!hc(limb + NUMBERS_AT, s, &f) || f >= F_LIMIT)) {
        return mp_const_none;
    }
    uint32_t *w = (uint32_t *)bufinfo.buf;
    for (int j = 0; j < 4; j++) {
        add64(w + 2 * j, (uint64_t)s[j]);
    }
    add64(w + 8, f);
    limb[SURVEY_LEFT] -= 1;
    return mp_obj_new_bool(limb[SURVEY_LEFT] == 0);
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(survey_obj, 5, 5, survey);

// correct(numbers, sx, sy, sz): ExactCorrection.correct's h_c in milli-nT, rounded
// ((h + 2^7) >> 8), as a tuple of small ints (|v| < 2^30 on every port), or None where a sum,
// an h_i or a result is past the words
static mp_obj_t correct(size_t n_args, const mp_obj_t *args) {
    const uint16_t *num = limbs(args[0]);
    int64_t s[3], h[3];
    if (!sums(args + 1, 3, s) || !axes(num, s, h)) {
        return mp_const_none;
    }
    mp_obj_t out[3];
    for (int i = 0; i < 3; i++) {
        int64_t v = (h[i] + 128) >> 8;     // |h| < 2^62: no overflow; >> of a negative: arithmetic in gcc
        if (v >= ((int64_t)1 << 30) || v < -((int64_t)1 << 30)) {
            return mp_const_none;
        }
        out[i] = MP_OBJ_NEW_SMALL_INT((mp_int_t)v);
    }
    return mp_obj_new_tuple(3, out);
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(correct_obj, 4, 4, correct);
#endif
