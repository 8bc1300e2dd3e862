// linalgc.c's kernels for one float type, included once per type: REAL (float, double), RNAME(name)
// (the type's name for each function), RUINT (its bits), RSQRT, RABS, RGET (a float object's value), RNEW (a new float).
// Each mirrors its function in shared/linalg.py line by line: keep them in step.
//
// Every operation's result goes through CK, as the interpreter would hand it on: an infinity or a
// nan sets *bad and the kernel hands the call back to Python (the rp2 port mends how the RP2040's ROM
// adds infinities); where the interpreter flushes subnormal results to zero (flush_subnormals: the
// ROM floats of MicroPython's rp2 port, where libgcc's keep them) a subnormal becomes a zero of its
// sign, and a result in [2^-126, 2^-125) also goes back to Python (where the ROM rounds before or
// after it flushes, the two could differ there: tests/test_native_linalg.py). Everything else is
// rounded once, correctly, on both sides: the same bits.

static __attribute__((noinline)) REAL RNAME(ck)(REAL x, bool *bad) {
    if (sizeof(REAL) == 4) {
        union { float f; uint32_t u; } v;
        v.f = (float)x;
        uint32_t e = (v.u >> 23) & 0xff;
        if (e == 0xff) {
            *bad = true;
        } else if (e <= 1 && flush_subnormals) {
            if (e == 1) {
                *bad = true;
            }
            v.u &= 0x80000000u;     // a zero of its sign, as the ROM gives (-0.0 for -(2^-70)^2)
            return (REAL)v.f;
        }
    } else {
        union { double d; uint64_t u; } v;
        v.d = (double)x;
        if ((~v.u & 0x7ff0000000000000u) == 0) {
            *bad = true;
        }
    }
    return x;
}

#define CK(x) RNAME(ck)((x), bad)

// comparisons on the bits, for the finite numbers the kernels compare (an infinity or a nan has set
// *bad first, and its result is not used): no libgcc compare routine linked (a board's heap)
typedef union { REAL r; RUINT u; } RNAME(word);
#define RSIGN ((RUINT)1 << (8 * sizeof(REAL) - 1))

static inline RUINT RNAME(bits)(REAL x) {
    RNAME(word) w;
    w.r = x;
    return w.u;
}

static inline bool RNAME(is_zero)(REAL x) {        // x == 0 (-0.0 too)
    return (RNAME(bits)(x) << 1) == 0;
}

static inline bool RNAME(is_positive)(REAL x) {    // x > 0
    RUINT u = RNAME(bits)(x);
    return !(u & RSIGN) && u != 0;
}

static inline bool RNAME(is_negative)(REAL x) {    // x < 0
    RUINT u = RNAME(bits)(x);
    return (u & RSIGN) && (u << 1) != 0;
}

static inline bool RNAME(abs_above)(REAL a, REAL b) {     // |a| > |b|
    return (RNAME(bits)(a) & ~RSIGN) > (RNAME(bits)(b) & ~RSIGN);
}

// a float object's value in *out, finite (and not subnormal where the interpreter makes none);
// false for anything else (Python decides)
static bool RNAME(value)(mp_obj_t o, REAL *out) {
    if (mp_obj_get_type(o) != float_type) {
        return false;
    }
    bool bad = false;
    REAL x = RGET(o);
    *out = RNAME(ck)(x, &bad);
    return !bad && (RNAME(is_zero)(x) || !RNAME(is_zero)(*out));    // not a subnormal flushed
}

// a list (or tuple) of n floats into v; n, or 0
static size_t RNAME(vector)(mp_obj_t o, REAL *v) {
    mp_obj_t *items;
    size_t n = items_of(o, &items);
    for (size_t i = 0; i < n; i++) {
        if (!RNAME(value)(items[i], &v[i])) {
            return 0;
        }
    }
    return n;
}

// a list of n lists of n floats into m (rows N_MAX apart); n, or 0
static size_t RNAME(matrix)(mp_obj_t o, REAL *m) {
    mp_obj_t *rows;
    size_t n = items_of(o, &rows);
    for (size_t i = 0; i < n; i++) {
        if (RNAME(vector)(rows[i], &m[i * N_MAX]) != n) {
            return 0;
        }
    }
    return n;
}

static mp_obj_t RNAME(new_vector)(const REAL *v, size_t n) {
    mp_obj_t items[N_MAX];
    for (size_t i = 0; i < n; i++) {
        items[i] = RNEW(v[i]);
    }
    return mp_obj_new_list(n, items);
}

// linalg.cholesky's loops on m (n x n) into low; false where Python raises (a pivot not positive)
static bool RNAME(factor)(const REAL *a, size_t n, REAL *low, bool *bad) {
    for (size_t j = 0; j < n; j++) {
        REAL s = a[j * N_MAX + j];
        REAL *row = &low[j * N_MAX];
        for (size_t k = 0; k < j; k++) {
            s = CK(s - CK(row[k] * row[k]));
        }
        if (!RNAME(is_positive)(s)) {
            return false;
        }
        REAL d = CK(RSQRT(s));
        row[j] = d;
        for (size_t i = j + 1; i < n; i++) {
            s = a[i * N_MAX + j];
            REAL *other = &low[i * N_MAX];
            for (size_t k = 0; k < j; k++) {
                s = CK(s - CK(other[k] * row[k]));
            }
            other[j] = CK(s / d);
        }
    }
    return true;
}

// linalg.cho_solve's loops, y in place (b on the way in); false where Python raises (a zero divisor)
static bool RNAME(substitute)(const REAL *low, size_t n, REAL *y, bool *bad) {
    for (size_t i = 0; i < n; i++) {
        REAL s = y[i];
        const REAL *row = &low[i * N_MAX];
        for (size_t k = 0; k < i; k++) {
            s = CK(s - CK(row[k] * y[k]));
        }
        if (RNAME(is_zero)(row[i])) {
            return false;
        }
        y[i] = CK(s / row[i]);
    }
    for (size_t i = n; i-- > 0;) {
        REAL s = y[i];
        for (size_t k = i + 1; k < n; k++) {
            s = CK(s - CK(low[k * N_MAX + i] * y[k]));
        }
        if (RNAME(is_zero)(low[i * N_MAX + i])) {
            return false;
        }
        y[i] = CK(s / low[i * N_MAX + i]);
    }
    return true;
}

static mp_obj_t RNAME(cholesky)(mp_obj_t a_in) {
    REAL a[N_MAX * N_MAX], low[N_MAX * N_MAX];
    size_t n = RNAME(matrix)(a_in, a);
    if (n == 0) {
        return mp_const_none;
    }
    for (size_t i = 0; i < n; i++) {
        for (size_t j = i + 1; j < n; j++) {
            low[i * N_MAX + j] = 0;
        }
    }
    bool bad = false;
    if (!RNAME(factor)(a, n, low, &bad) || bad) {
        return mp_const_none;
    }
    // Python's rows hold one zero object above the diagonal
    mp_obj_t zero = RNEW((REAL)0), rows[N_MAX], items[N_MAX];
    for (size_t i = 0; i < n; i++) {
        for (size_t j = 0; j < n; j++) {
            items[j] = j <= i ? RNEW(low[i * N_MAX + j]) : zero;
        }
        rows[i] = mp_obj_new_list(n, items);
    }
    return mp_obj_new_list(n, rows);
}

static mp_obj_t RNAME(cho_solve)(mp_obj_t low_in, mp_obj_t b_in) {
    REAL low[N_MAX * N_MAX], y[N_MAX];
    size_t n = RNAME(matrix)(low_in, low);
    bool bad = false;
    if (n == 0 || RNAME(vector)(b_in, y) != n || !RNAME(substitute)(low, n, y, &bad) || bad) {
        return mp_const_none;
    }
    return RNAME(new_vector)(y, n);
}

static mp_obj_t RNAME(solve_spd)(mp_obj_t a_in, mp_obj_t b_in) {
    REAL a[N_MAX * N_MAX], low[N_MAX * N_MAX], d[N_MAX], y[N_MAX];
    size_t n = RNAME(matrix)(a_in, a);
    if (n == 0 || RNAME(vector)(b_in, y) != n) {
        return mp_const_none;
    }
    bool flag = false, *bad = &flag;
    for (size_t i = 0; i < n; i++) {
        REAL aii = a[i * N_MAX + i];
        if (!RNAME(is_positive)(aii)) {
            return mp_const_none;
        }
        d[i] = CK((REAL)1 / CK(RSQRT(aii)));
    }
    // scaled[i][j] = row[j] * di * d[j], in a's place
    for (size_t i = 0; i < n; i++) {
        for (size_t j = 0; j < n; j++) {
            a[i * N_MAX + j] = CK(CK(a[i * N_MAX + j] * d[i]) * d[j]);
        }
        y[i] = CK(y[i] * d[i]);
    }
    if (!RNAME(factor)(a, n, low, bad) || !RNAME(substitute)(low, n, y, bad)) {
        return mp_const_none;
    }
    for (size_t i = 0; i < n; i++) {
        y[i] = CK(y[i] * d[i]);
    }
    if (flag) {
        return mp_const_none;
    }
    return RNAME(new_vector)(y, n);
}

// one Jacobi rotation of the columns p, q of the 3x3 m (rows 3 apart)
static void RNAME(rotate)(REAL *m, size_t p, size_t q, REAL c, REAL sn, bool *bad) {
    for (size_t k = 0; k < 3; k++) {
        REAL kp = m[k * 3 + p];
        REAL kq = m[k * 3 + q];
        m[k * 3 + p] = CK(CK(c * kp) - CK(sn * kq));
        m[k * 3 + q] = CK(CK(sn * kp) + CK(c * kq));
    }
}

static mp_obj_t RNAME(eigh3)(mp_obj_t s_in) {
    REAL s[N_MAX * N_MAX], a[9], v[9];
    if (RNAME(matrix)(s_in, s) != 3) {
        return mp_const_none;
    }
    for (size_t i = 0; i < 3; i++) {
        for (size_t j = 0; j < 3; j++) {
            a[i * 3 + j] = s[i * N_MAX + j];
            v[i * 3 + j] = i == j ? (REAL)1 : (REAL)0;
        }
    }
    static const uint8_t pairs[3][2] = {{0, 1}, {0, 2}, {1, 2}};
    const REAL one = 1, two = 2, big = (REAL)1e6;
    bool flag = false, *bad = &flag;
    for (int sweep = 0; sweep < 12; sweep++) {
        REAL off = CK(CK(RABS(a[1]) + RABS(a[2])) + RABS(a[5]));
        if (RNAME(is_zero)(off)) {
            break;
        }
        for (size_t r = 0; r < 3; r++) {
            size_t p = pairs[r][0], q = pairs[r][1];
            REAL *ap = &a[p * 3], *aq = &a[q * 3];
            REAL apq = ap[q];
            if (RNAME(is_zero)(apq)) {
                continue;
            }
            REAL diff = CK(aq[q] - ap[p]), t;
            if (RNAME(abs_above)(diff, CK(big * RABS(apq)))) {
                t = CK(apq / diff);     // a tiny angle (shared/linalg.py says why)
            } else {
                REAL theta = CK(diff / CK(two * apq));
                t = CK(one / CK(RABS(theta) + CK(RSQRT(CK(CK(theta * theta) + one)))));
                if (RNAME(is_negative)(theta)) {
                    t = -t;
                }
            }
            REAL c = CK(one / CK(RSQRT(CK(CK(t * t) + one))));
            REAL sn = CK(t * c);
            RNAME(rotate)(a, p, q, c, sn, bad);
            for (size_t k = 0; k < 3; k++) {
                REAL pk = ap[k];
                REAL qk = aq[k];
                ap[k] = CK(CK(c * pk) - CK(sn * qk));
                aq[k] = CK(CK(sn * pk) + CK(c * qk));
            }
            ap[q] = 0;
            aq[p] = 0;
            RNAME(rotate)(v, p, q, c, sn, bad);
        }
    }
    if (flag) {
        return mp_const_none;
    }
    REAL values[3], column[3];
    mp_obj_t vectors[3], out[2];
    values[0] = a[0];
    values[1] = a[4];
    values[2] = a[8];
    for (size_t k = 0; k < 3; k++) {
        column[0] = v[k];
        column[1] = v[3 + k];
        column[2] = v[6 + k];
        vectors[k] = RNAME(new_vector)(column, 3);
    }
    out[0] = RNAME(new_vector)(values, 3);
    out[1] = mp_obj_new_list(3, vectors);
    return mp_obj_new_tuple(2, out);
}
