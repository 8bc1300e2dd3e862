// linalgc.c's kernels of the solver's normal equations for one float type (included after
// linalg_body.h, with its REAL, RNAME, CK, value and vector): shared/quadric.py's normal_matrix and
// shared/iteration.py's add_prior, line by line, each operation rounded once and checked as there
// (linalg_body.h). Keep them in step with the Python, which stays the reference
// (tests/test_native_linalg.py compares the bits).

#define N_SUMS (35)     // shared.moments.COUNT: the power sums, by storage index

// The index tables normal_matrix reads (shared/quadric.py's, handed over by shared/linalg_native.py
// as one bytes object, so that the storage order is written down once): _IDX4 (6 x 6), the weights
// W_C[m] W_C[k] (6 x 6), _IDX3 (3 x 6), W_C (6), _IDX2M (3 x 3).
#define T_IDX4 (0)
#define T_W4 (36)
#define T_IDX3 (72)
#define T_WC (90)
#define T_IDX2M (96)
#define T_LEN (105)

// a list of n_rows (at most N_MAX) lists of 9 floats into m (rows N_MAX apart); n_rows, or 0
static size_t RNAME(rows9)(mp_obj_t o, REAL *m) {
    mp_obj_t *rows;
    size_t n = items_of(o, &rows);
    for (size_t i = 0; i < n; i++) {
        if (RNAME(vector)(rows[i], &m[i * N_MAX]) != 9) {
            return 0;
        }
    }
    return n;
}

// a + b + c as Python adds them: (a + b) + c
static inline REAL RNAME(sum3)(REAL a, REAL b, REAL c, bool *bad) {
    return CK(CK(a + b) + c);
}

// quadric.normal_matrix(mean, am, nf, num) for num float: H (a new list of 9 lists), or None
static mp_obj_t RNAME(normal_matrix)(mp_obj_t mean_in, mp_obj_t am_in, mp_obj_t nf_in, mp_obj_t tables_in) {
    mp_buffer_info_t tb;
    mp_obj_t *sums;
    size_t n_sums;
    REAL am[N_MAX * N_MAX], nf, mean[N_SUMS];
    if (!mp_get_buffer(tables_in, &tb, MP_BUFFER_READ) || tb.len != T_LEN
        || mp_obj_get_type(mean_in) != &mp_type_list || RNAME(matrix)(am_in, am) != 3 || !RNAME(value)(nf_in, &nf)) {
        return mp_const_none;
    }
    const uint8_t *t = tb.buf;
    mp_obj_get_array_dyn(mean_in, &n_sums, &sums);
    if (n_sums < N_SUMS) {      // (more: the sums' words after them, linalg_native._sums_at; not read)
        return mp_const_none;
    }
    // the sums the tables name (every one of degree 2..4), floats, each read once
    for (size_t k = 0; k < T_LEN; k++) {
        if (k >= T_W4 && k < T_IDX3) {
            continue;       // the weights, not indices
        }
        if (k >= T_WC && k < T_IDX2M) {
            continue;
        }
        if (t[k] >= N_SUMS || !RNAME(value)(sums[t[k]], &mean[t[k]])) {
            return mp_const_none;
        }
    }
    const REAL weights[3] = {1, 2, 4}, two = 2, four = 4;
    REAL m4[36], m3[18], m2[9], h[81], am2[9];
    bool flag = false, *bad = &flag;
    for (size_t m = 0; m < 6; m++) {
        for (size_t k = m; k < 6; k++) {
            REAL x = CK(CK(mean[t[T_IDX4 + m * 6 + k]] * weights[t[T_W4 + m * 6 + k] >> 1]) / nf);
            m4[m * 6 + k] = x;
            m4[k * 6 + m] = x;
        }
    }
    for (size_t i = 0; i < 3; i++) {
        for (size_t k = 0; k < 6; k++) {
            m3[i * 6 + k] = CK(CK(mean[t[T_IDX3 + i * 6 + k]] * weights[t[T_WC + k] >> 1]) / nf);
        }
    }
    for (size_t i = 0; i < 3; i++) {
        for (size_t j = i; j < 3; j++) {
            REAL x = CK(mean[t[T_IDX2M + i * 3 + j]] / nf);
            m2[i * 3 + j] = x;
            m2[j * 3 + i] = x;
        }
    }
    for (size_t m = 0; m < 6; m++) {
        for (size_t k = 0; k < 6; k++) {
            h[m * 9 + k] = m4[m * 6 + k];
        }
        for (size_t i = 0; i < 3; i++) {
            // d r / d f_i = -2 (A v)_i
            const REAL *ai = &am[i * N_MAX];
            REAL x = CK(-two * RNAME(sum3)(CK(ai[0] * m3[m]), CK(ai[1] * m3[6 + m]), CK(ai[2] * m3[12 + m]), bad));
            h[m * 9 + 6 + i] = x;
            h[(6 + i) * 9 + m] = x;
        }
    }
    for (size_t i = 0; i < 3; i++) {
        const REAL *ai = &am[i * N_MAX];
        for (size_t j = 0; j < 3; j++) {
            am2[i * 3 + j] = RNAME(sum3)(CK(ai[0] * m2[j]), CK(ai[1] * m2[3 + j]), CK(ai[2] * m2[6 + j]), bad);
        }
    }
    for (size_t i = 0; i < 3; i++) {
        for (size_t k = 0; k < 3; k++) {
            const REAL *a2 = &am2[i * 3];
            h[(6 + i) * 9 + 6 + k] = CK(four * RNAME(sum3)(CK(a2[0] * am[k]), CK(a2[1] * am[N_MAX + k]),
                                                              CK(a2[2] * am[2 * N_MAX + k]), bad));
        }
    }
    if (flag) {
        return mp_const_none;
    }
    // the Python's objects: one float for an entry and its mirror (m4's blocks, the f columns)
    mp_obj_t objs[81], rows[9];
    for (size_t i = 0; i < 9; i++) {
        for (size_t j = 0; j < 9; j++) {
            bool mirrored = j < i && (i < 6 || j < 6);
            objs[i * 9 + j] = mirrored ? objs[j * 9 + i] : RNEW(h[i * 9 + j]);
        }
    }
    for (size_t i = 0; i < 9; i++) {
        rows[i] = mp_obj_new_list(9, &objs[i * 9]);
    }
    return mp_obj_new_list(9, rows);
}

// iteration.add_prior(h, g, rho, jac, lam, zero) in place: True, or None (nothing changed: Python's)
static mp_obj_t RNAME(add_prior)(size_t n_args, const mp_obj_t *args) {
    REAL h[N_MAX * N_MAX], g[N_MAX], rho[N_MAX], jac[N_MAX * N_MAX], lam;
    mp_obj_t h_in = args[0], g_in = args[1];
    bool with_h = h_in != mp_const_none;
    size_t n_rho = RNAME(vector)(args[2], rho);
    if (RNAME(vector)(g_in, g) != 9 || mp_obj_get_type(g_in) != &mp_type_list || n_rho == 0
        || RNAME(rows9)(args[3], jac) != n_rho || !RNAME(value)(args[4], &lam)) {
        return mp_const_none;
    }
    mp_obj_t *h_rows = NULL;
    if (with_h) {
        if (mp_obj_get_type(h_in) != &mp_type_list || RNAME(matrix)(h_in, h) != 9) {
            return mp_const_none;
        }
        size_t n;
        mp_obj_get_array_dyn(h_in, &n, &h_rows);
        for (size_t i = 0; i < 9; i++) {
            if (mp_obj_get_type(h_rows[i]) != &mp_type_list || h_rows[i] == g_in) {
                return mp_const_none;
            }
            for (size_t j = 0; j < i; j++) {
                if (h_rows[i] == h_rows[j]) {
                    return mp_const_none;   // one list twice: Python's updates would add up in it
                }
            }
        }
    }
    bool touched[9], flag = false, *bad = &flag;
    for (size_t i = 0; i < 9; i++) {
        touched[i] = false;     // (a loop: an initialiser is a memset call, which a native module lacks)
    }
    for (size_t r = 0; r < n_rho; r++) {
        const REAL *row = &jac[r * N_MAX];
        for (size_t i = 0; i < 9; i++) {
            REAL ri = row[i];
            if (RNAME(is_zero)(ri)) {
                continue;
            }
            REAL lr = CK(lam * ri);      // (lam row[i]) row[k], as the Python writes it
            g[i] = CK(g[i] + CK(lr * rho[r]));
            touched[i] = true;
            if (with_h) {
                REAL *hi = &h[i * N_MAX];
                for (size_t k = 0; k < 9; k++) {
                    hi[k] = CK(hi[k] + CK(lr * row[k]));
                }
            }
        }
    }
    if (flag) {
        return mp_const_none;
    }
    mp_obj_t *items;
    size_t n;
    mp_obj_get_array_dyn(g_in, &n, &items);
    for (size_t i = 0; i < 9; i++) {
        if (!touched[i]) {
            continue;
        }
        items[i] = RNEW(g[i]);
        if (with_h) {
            mp_obj_t *hi;
            mp_obj_get_array_dyn(h_rows[i], &n, &hi);
            for (size_t k = 0; k < 9; k++) {
                hi[k] = RNEW(h[i * N_MAX + k]);
            }
        }
    }
    return mp_const_true;
}

// prior.Prior.residuals(self, a, f) for num float: (rho, jac), or None. The prior's own numbers come
// as its attributes (linalgc.c reads them): kr, q_target, q_sigma, f_target, f_sigma, t_target, t_sigma.
static mp_obj_t RNAME(prior_residuals)(const mp_obj_t *attrs, mp_obj_t a_in, mp_obj_t f_in) {
    REAL a[N_MAX], f[N_MAX], kr[N_MAX], qt[N_MAX], qs[N_MAX], ft[N_MAX], fs = 0, tt = 0, ts = 0;
    bool with_f = attrs[3] != mp_const_none, with_t = attrs[5] != mp_const_none;
    if (RNAME(vector)(a_in, a) != 6 || RNAME(vector)(f_in, f) != 3 || RNAME(vector)(attrs[0], kr) != 3
        || RNAME(vector)(attrs[1], qt) != 6 || RNAME(vector)(attrs[2], qs) != 6
        || (with_f && (RNAME(vector)(attrs[3], ft) != 3 || !RNAME(value)(attrs[4], &fs)))
        || (with_t && (!RNAME(value)(attrs[5], &tt) || !RNAME(value)(attrs[6], &ts)))) {
        return mp_const_none;
    }
    static const uint8_t pair[6][2] = {{0, 0}, {1, 1}, {2, 2}, {0, 1}, {0, 2}, {1, 2}};    // quadric.PAIR
    const REAL one = 1, three = 3, zero = 0;
    bool flag = false, *bad = &flag;
    // shape(a): A' = K^-1 A K^-1, t = tr A' / 3, q = A'/t - I
    REAL ap[6], q[6], dt[6], rho[10], jac[10 * 9];
    for (size_t m = 0; m < 6; m++) {
        ap[m] = CK(a[m] / CK(kr[pair[m][0]] * kr[pair[m][1]]));
    }
    REAL t = CK(RNAME(sum3)(ap[0], ap[1], ap[2], bad) / three);
    for (size_t m = 0; m < 6; m++) {
        q[m] = CK(CK(ap[m] / t) - (m < 3 ? one : zero));
    }
    // d t / d a_m is 1/(3 k_m^2) for the diagonal terms, 0 otherwise
    for (size_t m = 0; m < 6; m++) {
        dt[m] = m < 3 ? CK(one / CK(CK(three * kr[m]) * kr[m])) : zero;
    }
    size_t n = 0;
    for (size_t i = 0; i < 6; i++, n++) {
        rho[n] = CK(CK(q[i] - qt[i]) / qs[i]);
        REAL *row = &jac[n * 9];
        for (size_t m = 0; m < 9; m++) {
            row[m] = zero;
        }
        for (size_t m = 0; m < 6; m++) {
            REAL d = CK(CK(-ap[i] * dt[m]) / CK(t * t));
            if (m == i) {
                d = CK(d + CK(one / CK(CK(kr[pair[m][0]] * kr[pair[m][1]]) * t)));
            }
            row[m] = CK(d / qs[i]);
        }
    }
    if (with_f) {
        for (size_t i = 0; i < 3; i++, n++) {
            rho[n] = CK(CK(f[i] - ft[i]) / fs);
            for (size_t m = 0; m < 9; m++) {
                jac[n * 9 + m] = zero;
            }
            jac[n * 9 + 6 + i] = CK(one / fs);
        }
    }
    if (with_t) {
        rho[n] = CK(CK(CK(t / tt) - one) / ts);
        for (size_t m = 0; m < 9; m++) {
            jac[n * 9 + m] = m < 3 ? CK(dt[m] / CK(tt * ts)) : zero;
        }
        n++;
    }
    if (flag) {
        return mp_const_none;
    }
    // the Python's rows hold one zero object where nothing was set (its [zero] * 9)
    mp_obj_t zero_obj = RNEW(zero), rows[10], items[9], out[2];
    for (size_t r = 0; r < n; r++) {
        for (size_t m = 0; m < 9; m++) {
            bool set = r < 6 ? m < 6 : (with_f && r < 9) ? m == 6 + (r - 6) : m < 3;
            items[m] = set ? RNEW(jac[r * 9 + m]) : zero_obj;
        }
        rows[r] = mp_obj_new_list(9, items);
    }
    out[0] = RNAME(new_vector)(rho, n);
    out[1] = mp_obj_new_list(n, rows);
    return mp_obj_new_tuple(2, out);
}

// moments.to_float(x, exponent) of the words x (exact_body.h) as this interpreter makes it: the top 53
// bits by a floor shift, float() of that int (a small int's C conversion; a bigger one's py/mpz.c
// mpz_as_float, its 16-bit digits from the top: val = val * 2**16 + d, each sum rounded), math.ldexp
// (exact where the result is a normal number: its exponent field moved; the interpreter's own elsewhere)
static mp_obj_t RNAME(word_float)(const uint32_t *x, mp_int_t exponent) {
    uint32_t y[EW];
    mp_int_t extra = e_bits(x) - 53;
    e_shift_right(y, x, extra > 0 ? extra : 0);
    exponent += extra > 0 ? extra : 0;
    int64_t v = (int64_t)((uint64_t)y[0] | (uint64_t)y[1] << 32);     // |v| <= 2**53
    REAL val = 0;
    if (v >= MP_SMALL_INT_MIN && v <= MP_SMALL_INT_MAX) {
        val = (REAL)(mp_int_t)v;
    } else {
        uint64_t m = v < 0 ? -(uint64_t)v : (uint64_t)v;
        for (int k = 48; k >= 0; k -= 16) {
            val = val * (REAL)65536 + (REAL)(uint32_t)((m >> k) & 0xffff);
        }
        val = v < 0 ? -val : val;
    }
    const size_t mant = sizeof(REAL) == 4 ? 23 : 52;
    const mp_int_t top = sizeof(REAL) == 4 ? 0xff : 0x7ff;
    union { REAL r; RUINT u; } b = {val};
    mp_int_t e = (mp_int_t)((b.u >> mant) & (RUINT)top) + exponent;
    if (val == 0 || (e >= 1 && e < top)) {
        b.u = val == 0 ? b.u : (b.u & ~((RUINT)top << mant)) | ((RUINT)e << mant);
        return RNEW(b.r);
    }
    mp_obj_t call[2] = {RNEW(val), MP_OBJ_NEW_SMALL_INT(exponent)};
    return mp_call_function_n_kw(ldexp_fn, 2, 0, call);
}

// quadric.frame_means(s, indices, num) for num float from the sums' words (linalg_native._sums_at): the
// sums at `indices` as floats in the frame, to_float(s[i], -degrees[i] frac), in a list by storage index
static mp_obj_t RNAME(frame_floats)(const uint32_t *s, const uint8_t *indices, size_t n, const uint8_t *degrees,
                                    mp_int_t frac) {
    mp_obj_t out[N_SUMS];
    for (size_t i = 0; i < N_SUMS; i++) {
        out[i] = mp_const_none;
    }
    for (size_t k = 0; k < n; k++) {
        out[indices[k]] = RNAME(word_float)(s + EW * indices[k], -(mp_int_t)degrees[indices[k]] * frac);
    }
    return mp_obj_new_list(N_SUMS, out);
}
