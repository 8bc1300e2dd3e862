// exact.h: the solver's exact integer kernels (shared/quadric.py Problem.sums_at, Problem.exact,
// and the 53-bit cuts of shared.moments.to_float) in machine words, for fitsums.c (included
// after mul32):
//
//     recentre(src, dst, centre, chains)     # shared.moments.recentred: True, or False (past the words)
//     exact(s, a, n, tables, out)           # Problem.exact's g_A, T, RSS into out: True, or False
//     tops(s, cut, extra)                   # to_float's cut of each of the 35 sums
//
// A number is SOLVE_WORDS 32-bit words of two's complement, least significant first (320 bits:
// the solver's sums of V = 2^40 v reach about 2^(160 + log2 n) at degree 4, its RSS 2^(240 +
// log2 n)); s, src, dst are 35 of them (shared.moments.ORDER), out 10 (g_A[0..5], T[0..2],
// RSS). centre and a are 64-bit two's complements (3 and 6, in bytes). Every product and sum
// is checked: where one would pass the words the call returns False, having written nothing
// the caller reads, and the caller runs the pure-Python integers instead. The index tables
// (chains, tables) come from shared/ (moments._CHAINS, quadric's _IDX*), so the storage order
// is defined once. No floats here: the floats are made in Python from the same integers.

#define SOLVE_WORDS (10)
#define SOLVE_SUMS (35)
#define SOLVE_OUT (10)
#define SOLVE_FRAC (40)       // shared.quadric.FRAC: Problem.exact's shifts are 3 and 6 FRAC

typedef struct { uint32_t w[SOLVE_WORDS]; } wide_t;

// (word by word, volatile: a struct copy or a plain loop may become a memcpy or memset, which
// are not linked)
static void copy(wide_t *dst, const wide_t *src) {
    volatile uint32_t *d = dst->w;
    for (int i = 0; i < SOLVE_WORDS; i++) {
        d[i] = src->w[i];
    }
}

static void zero(wide_t *dst) {
    volatile uint32_t *d = dst->w;
    for (int i = 0; i < SOLVE_WORDS; i++) {
        d[i] = 0;
    }
}

static inline bool wide_negative(const wide_t *x) {
    return (x->w[SOLVE_WORDS - 1] >> 31) != 0;
}

// acc += sign * (x * c) for a 64-bit magnitude c = c0 + 2^32 c1; false where the product or
// the sum passes the words' signed range (acc is then garbage: the caller gives up)
static bool wide_muladd(wide_t *acc, const wide_t *x, uint32_t c0, uint32_t c1, bool negate) {
    uint32_t m[SOLVE_WORDS];
    bool neg = wide_negative(x);
    uint32_t flip = neg ? 0xffffffff : 0;
    uint64_t carry = neg ? 1 : 0;
    for (int i = 0; i < SOLVE_WORDS; i++) {         // |x|
        carry += x->w[i] ^ flip;
        m[i] = (uint32_t)carry;
        carry >>= 32;
    }
    uint32_t p[SOLVE_WORDS + 2];
    uint64_t t = 0;
    for (int i = 0; i < SOLVE_WORDS; i++) {         // |x| c0
        t += mul32(m[i], c0);
        p[i] = (uint32_t)t;
        t >>= 32;
    }
    p[SOLVE_WORDS] = (uint32_t)t;
    p[SOLVE_WORDS + 1] = 0;
    if (c1) {
        t = 0;
        for (int i = 0; i < SOLVE_WORDS; i++) {     // + |x| c1 2^32
            t += mul32(m[i], c1);
            t += p[i + 1];
            p[i + 1] = (uint32_t)t;
            t >>= 32;
        }
        p[SOLVE_WORDS + 1] = (uint32_t)t;
    }
    if (p[SOLVE_WORDS] || p[SOLVE_WORDS + 1] || (p[SOLVE_WORDS - 1] >> 31)) {
        return false;
    }
    bool sub = neg != negate;
    bool before = wide_negative(acc);
    flip = sub ? 0xffffffff : 0;
    carry = sub ? 1 : 0;
    for (int i = 0; i < SOLVE_WORDS; i++) {
        carry += (uint64_t)acc->w[i] + (p[i] ^ flip);
        acc->w[i] = (uint32_t)carry;
        carry >>= 32;
    }
    // a signed overflow: adding a positive to a non-negative gave a negative, or subtracting
    // one from a negative gave a non-negative
    return sub ? !(before && !wide_negative(acc)) : !(!before && wide_negative(acc));
}

// acc -= x << bits (or += when add), x >= 0 or not; false past the words
static bool wide_shift_add(wide_t *acc, const wide_t *x, int bits, bool add) {
    wide_t y;
    int q = bits >> 5, r = bits & 31;
    uint32_t fill = wide_negative(x) ? 0xffffffff : 0;
    for (int i = SOLVE_WORDS - 1; i >= 0; i--) {
        uint32_t hi = i - q >= 0 ? x->w[i - q] : 0;
        uint32_t lo = i - q - 1 >= 0 ? x->w[i - q - 1] : 0;
        y.w[i] = r ? (hi << r) | (lo >> (32 - r)) : hi;
    }
    // x << bits fits where x's top bits + 1 (from bit 32 WORDS - 1 - bits up) are copies of its sign
    int start = 32 * SOLVE_WORDS - 1 - bits;
    for (int i = start >> 5; i < SOLVE_WORDS; i++) {
        uint32_t mask = 32 * i >= start ? 0xffffffff : (0xffffffff << (start & 31));
        if ((x->w[i] ^ fill) & mask) {
            return false;
        }
    }
    return wide_muladd(acc, &y, 1, 0, !add);
}

// a buffer of at least `count` numbers, read-write when `write`
static wide_t *wides(mp_obj_t o, int count, int flags) {
    mp_buffer_info_t bufinfo;
    mp_get_buffer_raise(o, &bufinfo, flags);
    if (bufinfo.len < count * sizeof(wide_t)) {
        mp_raise_ValueError(MP_ERROR_TEXT("fitsums: buffer holds too few numbers"));
    }
    return (wide_t *)bufinfo.buf;
}

// the `count` 64-bit two's complements of a bytes object as signs and magnitudes
static void signed64(mp_obj_t o, int count, uint32_t *mag, bool *neg) {
    mp_buffer_info_t bufinfo;
    mp_get_buffer_raise(o, &bufinfo, MP_BUFFER_READ);
    if (bufinfo.len < count * 8) {
        mp_raise_ValueError(MP_ERROR_TEXT("fitsums: too few 64-bit numbers"));
    }
    const uint8_t *b = (const uint8_t *)bufinfo.buf;
    for (int k = 0; k < count; k++, b += 8) {
        uint32_t lo = b[0] | ((uint32_t)b[1] << 8) | ((uint32_t)b[2] << 16) | ((uint32_t)b[3] << 24);
        uint32_t hi = b[4] | ((uint32_t)b[5] << 8) | ((uint32_t)b[6] << 16) | ((uint32_t)b[7] << 24);
        neg[k] = (hi >> 31) != 0;
        if (neg[k]) {                   // -v: ~v + 1 (2^63 itself stays 2^63 as a magnitude)
            lo = ~lo + 1;
            hi = ~hi + (lo == 0);
        }
        mag[2 * k] = lo;
        mag[2 * k + 1] = hi;
    }
}

static const uint8_t *table(mp_obj_t o, size_t need) {
    mp_buffer_info_t bufinfo;
    mp_get_buffer_raise(o, &bufinfo, MP_BUFFER_READ);
    if (bufinfo.len < need) {
        mp_raise_ValueError(MP_ERROR_TEXT("fitsums: table too short"));
    }
    return (const uint8_t *)bufinfo.buf;
}

// recentre(src, dst, centre, chains): dst = the 35 sums src re-centred on centre (three 64-bit
// numbers), axis by axis as shared.moments._taylor: along each chain m x^0 .. m x^d of an axis,
// passes k = 1 .. d of M_t -= c M_(t-1) for t from the top down to k. chains: the three axes'
// moments._CHAINS, each prefixed by its length in one byte. True, or False past the words.
static mp_obj_t recentre(size_t n_args, const mp_obj_t *args) {
    const wide_t *src = wides(args[0], SOLVE_SUMS, MP_BUFFER_READ);
    wide_t *s = wides(args[1], SOLVE_SUMS, MP_BUFFER_RW);
    uint32_t c[6];
    bool neg[3];
    signed64(args[2], 3, c, neg);
    mp_buffer_info_t bufinfo;
    mp_get_buffer_raise(args[3], &bufinfo, MP_BUFFER_READ);
    const uint8_t *chains = (const uint8_t *)bufinfo.buf;
    size_t len = bufinfo.len;
    for (int n = 0; n < SOLVE_SUMS; n++) {
        copy(&s[n], &src[n]);
    }
    size_t at = 0;
    for (int axis = 0; axis < 3; axis++) {
        if (at >= len) {
            mp_raise_ValueError(MP_ERROR_TEXT("fitsums: chains too short"));
        }
        size_t end = at + 1 + chains[at];
        if (end > len) {
            mp_raise_ValueError(MP_ERROR_TEXT("fitsums: chains too short"));
        }
        at++;
        if (c[2 * axis] == 0 && c[2 * axis + 1] == 0) {
            at = end;
            continue;
        }
        size_t p = at;
        while (p < end) {
            size_t top = p + chains[p];         // the chain is chains[p + 1 .. top]
            if (top >= end) {
                mp_raise_ValueError(MP_ERROR_TEXT("fitsums: bad chain"));
            }
            for (size_t k = p + 2; k <= top; k++) {
                for (size_t e = top; e >= k; e--) {
                    uint8_t upper = chains[e], lower = chains[e - 1];
                    if (upper >= SOLVE_SUMS || lower >= SOLVE_SUMS) {
                        mp_raise_ValueError(MP_ERROR_TEXT("fitsums: bad chain"));
                    }
                    // s[upper] -= c s[lower]
                    if (!wide_muladd(&s[upper], &s[lower], c[2 * axis], c[2 * axis + 1], !neg[axis])) {
                        return mp_const_false;
                    }
                }
            }
            p = top + 1;
        }
        at = end;
    }
    return mp_const_true;
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(recentre_obj, 4, 4, recentre);

// exact(s, a, n, tables, out): Problem.exact into out (10 numbers). a: a_int, six 64-bit numbers;
// n: the count, a small int 0 <= n < 2^30; tables: quadric's _IDX4 (36 bytes, row by row),
// _IDX3 (18), _IDX2 (6), _IDX1 (3). With ac = (a0, a1, a2, 2 a3, 2 a4, 2 a5):
//     g_A[m] = W_C[m] (sum_k ac_k S[IDX4[m][k]] - 2^3F S[IDX2[m]])   (W_C: 1, 1, 1, 2, 2, 2)
//     T[i] = sum_k ac_k S[IDX3[i][k]] - 2^3F S[IDX1[i]]
//     RSS = 2^6F n - 2^3F sum_k ac_k S[IDX2[k]] + sum_m a_m g_A[m]
static mp_obj_t exact(size_t n_args, const mp_obj_t *args) {
    const wide_t *s = wides(args[0], SOLVE_SUMS, MP_BUFFER_READ);
    uint32_t a[12], ac[12];
    bool neg[6];
    signed64(args[1], 6, a, neg);
    int64_t count;
    if (!small_within(args[2], (int64_t)1 << 30, &count) || count < 0) {
        return mp_const_false;
    }
    const uint8_t *idx = table(args[3], 63);
    for (int i = 0; i < 63; i++) {
        if (idx[i] >= SOLVE_SUMS) {
            mp_raise_ValueError(MP_ERROR_TEXT("fitsums: bad index"));
        }
    }
    wide_t *out = wides(args[4], SOLVE_OUT, MP_BUFFER_RW);
    for (int k = 0; k < 6; k++) {
        ac[2 * k] = a[2 * k];
        ac[2 * k + 1] = a[2 * k + 1];
        if (k >= 3) {                   // 2 a_k, its magnitude still in 64 bits
            if (a[2 * k + 1] >> 31) {
                return mp_const_false;
            }
            ac[2 * k + 1] = (a[2 * k + 1] << 1) | (a[2 * k] >> 31);
            ac[2 * k] = a[2 * k] << 1;
        }
    }
    wide_t acc;
    // rows 0..5: g_A; 6..8: T; 9: the linear term of the RSS (sum_k ac_k S[IDX2[k]])
    for (int row = 0; row < 10; row++) {
        const uint8_t *r = row < 6 ? idx + 6 * row : row < 9 ? idx + 36 + 6 * (row - 6) : idx + 54;
        zero(&acc);
        for (int k = 0; k < 6; k++) {
            if (!wide_muladd(&acc, &s[r[k]], ac[2 * k], ac[2 * k + 1], neg[k])) {
                return mp_const_false;
            }
        }
        if (row < 9) {
            uint8_t lin = row < 6 ? idx[54 + row] : idx[60 + row - 6];
            if (!wide_shift_add(&acc, &s[lin], 3 * SOLVE_FRAC, false)) {
                return mp_const_false;
            }
        }
        if (row < 3 || row >= 6) {
            copy(&out[row], &acc);
        } else {
            zero(&out[row]);
            if (!wide_muladd(&out[row], &acc, 2, 0, false)) {
                return mp_const_false;
            }
        }
    }
    // RSS = 2^6F n - 2^3F lin + sum_m a_m g_A[m], into out[9] (which holds lin)
    zero(&acc);
    acc.w[0] = (uint32_t)count;
    wide_t rss;
    zero(&rss);
    if (!wide_shift_add(&rss, &acc, 6 * SOLVE_FRAC, true) || !wide_shift_add(&rss, &out[9], 3 * SOLVE_FRAC, false)) {
        return mp_const_false;
    }
    for (int m = 0; m < 6; m++) {
        if (!wide_muladd(&rss, &out[m], a[2 * m], a[2 * m + 1], neg[m])) {
            return mp_const_false;
        }
    }
    copy(&out[9], &rss);
    return mp_const_true;
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(exact_obj, 5, 5, exact);

// tops(s, cut, extra): for each of the 35 sums x, shared.moments.to_float's integer step:
// extra = max(bit_length(|x|) - 53, 0) and cut = x >> extra (a floor), into cut (an
// array("q"), 35) and extra (an array("H"), 35). to_float(x, e) is then ldexp(float(cut), e + extra).
static mp_obj_t tops(size_t n_args, const mp_obj_t *args) {
    const wide_t *s = wides(args[0], SOLVE_SUMS, MP_BUFFER_READ);
    mp_buffer_info_t bufinfo;
    mp_get_buffer_raise(args[1], &bufinfo, MP_BUFFER_RW);
    if (bufinfo.len < SOLVE_SUMS * 8) {
        mp_raise_ValueError(MP_ERROR_TEXT("fitsums: cut holds fewer than 35 numbers"));
    }
    uint32_t *cut = (uint32_t *)bufinfo.buf;
    mp_get_buffer_raise(args[2], &bufinfo, MP_BUFFER_RW);
    if (bufinfo.len < SOLVE_SUMS * sizeof(uint16_t)) {
        mp_raise_ValueError(MP_ERROR_TEXT("fitsums: extra holds fewer than 35 numbers"));
    }
    uint16_t *extra = (uint16_t *)bufinfo.buf;
    for (int n = 0; n < SOLVE_SUMS; n++) {
        const uint32_t *w = s[n].w;
        uint32_t fill = wide_negative(&s[n]) ? 0xffffffff : 0;
        // bit_length(|x|): for x < 0, |x| = ~x + 1, whose length is that of ~x except at
        // x = -2^k (~x = 2^k - 1, one bit shorter): found from the words of ~x
        uint32_t m[SOLVE_WORDS];
        for (int i = 0; i < SOLVE_WORDS; i++) {
            m[i] = w[i] ^ fill;
        }
        int bits = 0;
        for (int i = SOLVE_WORDS - 1; i >= 0; i--) {
            if (m[i]) {
                uint32_t v = m[i];
                int b = 0;
                while (v) {
                    v >>= 1;
                    b++;
                }
                bits = 32 * i + b;
                break;
            }
        }
        if (fill) {         // |x| = ~x + 1: one bit longer where ~x is all ones below its length
            bool ones = true;
            for (int i = 0; i < SOLVE_WORDS && 32 * i < bits; i++) {
                uint32_t want = 32 * (i + 1) <= bits ? 0xffffffff : (((uint32_t)1 << (bits - 32 * i)) - 1);
                if (m[i] != want) {
                    ones = false;
                    break;
                }
            }
            if (ones) {
                bits++;
            }
        }
        int e = bits > 53 ? bits - 53 : 0;
        int q = e >> 5, r = e & 31;
        // the 64 bits of x >> e (arithmetic: the sign's copies come in from the top)
        uint32_t lo0 = q < SOLVE_WORDS ? w[q] : fill, lo1 = q + 1 < SOLVE_WORDS ? w[q + 1] : fill;
        uint32_t lo2 = q + 2 < SOLVE_WORDS ? w[q + 2] : fill;
        cut[2 * n] = r ? (lo0 >> r) | (lo1 << (32 - r)) : lo0;
        cut[2 * n + 1] = r ? (lo1 >> r) | (lo2 << (32 - r)) : lo1;
        extra[n] = (uint16_t)e;          // up to 320 - 53: past a byte
    }
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(tops_obj, 3, 3, tops);
