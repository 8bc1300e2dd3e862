// linalgc.c's kernels of the predicted full-sphere error for one float type (included after
// linalg_body.h, with its REAL, RNAME, CK, value, vector, matrix and substitute): shared/predicted.py's
// _sphere_gradients, _variance_sum and _bias_spread, line by line, each operation rounded once and
// checked as there (linalg_body.h). Keep them in step with the Python, which stays the reference
// (tests/test_native_linalg.py compares the bits).

#define N_DIRECTIONS (12)   // predicted._ICO: the icosahedron's vertices

// predicted._sphere_gradients(values, vectors, am, num) for num float, with predicted._ICO handed
// over (its floats are the interpreter's own): the 12 gradients, or None
static mp_obj_t RNAME(sphere_gradients)(size_t n_args, const mp_obj_t *args) {
    REAL values[N_MAX], vectors[N_MAX * N_MAX], am[N_MAX * N_MAX], ico[N_MAX * N_MAX];
    mp_obj_t *directions;
    if (RNAME(vector)(args[0], values) != 3 || RNAME(matrix)(args[1], vectors) != 3 || RNAME(matrix)(args[2], am) != 3
        || items_of(args[3], &directions) != N_DIRECTIONS) {
        return mp_const_none;
    }
    for (size_t d = 0; d < N_DIRECTIONS; d++) {
        if (RNAME(vector)(directions[d], &ico[d * 3]) != 3) {
            return mp_const_none;
        }
    }
    bool flag = false, *bad = &flag;
    const REAL one = 1, two = 2;
    // linalg.sym_function(values, vectors, lambda l: 1 / sqrt(l)): V diag(f(values)) V^T
    REAL fv[3], inv_sqrt[9];
    for (size_t k = 0; k < 3; k++) {
        if (!RNAME(is_positive)(values[k])) {
            return mp_const_none;   // Python raises (a math domain error, a zero divisor)
        }
        fv[k] = CK(one / CK(RSQRT(values[k])));
    }
    for (size_t i = 0; i < 3; i++) {
        for (size_t j = 0; j < 3; j++) {
            REAL terms[3];
            for (size_t k = 0; k < 3; k++) {
                const REAL *vk = &vectors[k * N_MAX];
                terms[k] = CK(CK(vk[i] * fv[k]) * vk[j]);
            }
            inv_sqrt[i * 3 + j] = RNAME(sum3)(terms[0], terms[1], terms[2], bad);
        }
    }
    mp_obj_t rows[N_DIRECTIONS], items[9];
    REAL out[N_DIRECTIONS * 9];
    for (size_t d = 0; d < N_DIRECTIONS; d++) {
        const REAL *u = &ico[d * 3];
        REAL v[3], av[3];
        for (size_t i = 0; i < 3; i++) {        // linalg.matvec(inv_sqrt, u)
            const REAL *row = &inv_sqrt[i * 3];
            v[i] = RNAME(sum3)(CK(row[0] * u[0]), CK(row[1] * u[1]), CK(row[2] * u[2]), bad);
        }
        for (size_t i = 0; i < 3; i++) {        // linalg.matvec(am, v)
            const REAL *row = &am[i * N_MAX];
            av[i] = RNAME(sum3)(CK(row[0] * v[0]), CK(row[1] * v[1]), CK(row[2] * v[2]), bad);
        }
        REAL *g = &out[d * 9];
        g[0] = CK(CK(v[0] * v[0]) / two);
        g[1] = CK(CK(v[1] * v[1]) / two);
        g[2] = CK(CK(v[2] * v[2]) / two);
        g[3] = CK(v[0] * v[1]);
        g[4] = CK(v[0] * v[2]);
        g[5] = CK(v[1] * v[2]);
        g[6] = -av[0];
        g[7] = -av[1];
        g[8] = -av[2];
    }
    if (flag) {
        return mp_const_none;
    }
    for (size_t d = 0; d < N_DIRECTIONS; d++) {
        for (size_t k = 0; k < 9; k++) {
            items[k] = RNEW(out[d * 9 + k]);
        }
        rows[d] = mp_obj_new_list(9, items);
    }
    return mp_obj_new_list(N_DIRECTIONS, rows);
}

// predicted._variance_sum(low, grads, None, num) for num float: sum over the gradients g of
// g . cho_solve(low, g), or None
static mp_obj_t RNAME(variance_sum)(mp_obj_t low_in, mp_obj_t grads_in) {
    REAL low[N_MAX * N_MAX], y[N_MAX], g[N_MAX];
    mp_obj_t *grads;
    size_t n = RNAME(matrix)(low_in, low), n_grads = items_of(grads_in, &grads);
    if (n == 0 || mp_obj_get_type(grads_in) != &mp_type_list) {
        return mp_const_none;
    }
    bool flag = false, *bad = &flag;
    REAL total = 0;
    for (size_t d = 0; d < n_grads; d++) {
        if (RNAME(vector)(grads[d], g) != n) {
            return mp_const_none;
        }
        for (size_t i = 0; i < n; i++) {
            y[i] = g[i];
        }
        if (!RNAME(substitute)(low, n, y, bad)) {
            return mp_const_none;   // a zero divisor: Python raises
        }
        for (size_t i = 0; i < n; i++) {
            total = CK(total + CK(g[i] * y[i]));
        }
    }
    return flag ? mp_const_none : RNEW(total);
}

// predicted._bias_spread(grads, bias, None, centred, num) for num float: the mean square over the
// gradients gd of gd . bias about their mean (centred) or about 0, or None
static mp_obj_t RNAME(bias_spread)(mp_obj_t grads_in, mp_obj_t bias_in, mp_obj_t centred) {
    REAL bias[N_MAX], gd[N_MAX], errs[N_MAX];
    mp_obj_t *grads;
    size_t n = RNAME(vector)(bias_in, bias), n_grads = items_of(grads_in, &grads);
    if (n == 0 || n_grads == 0 || mp_obj_get_type(grads_in) != &mp_type_list) {
        return mp_const_none;
    }
    bool flag = false, *bad = &flag;
    for (size_t d = 0; d < n_grads; d++) {
        if (RNAME(vector)(grads[d], gd) != n) {
            return mp_const_none;
        }
        REAL e = 0;
        for (size_t i = 0; i < n; i++) {
            e = CK(e + CK(gd[i] * bias[i]));
        }
        errs[d] = e;
    }
    REAL k = (REAL)n_grads, mean = 0, total = 0;
    if (mp_obj_is_true(centred)) {
        REAL s = 0;             // Python's sum(): 0 + errs[0] + ..., the int 0 as 0.0
        for (size_t d = 0; d < n_grads; d++) {
            s = CK(s + errs[d]);
        }
        mean = CK(s / k);
    }
    for (size_t d = 0; d < n_grads; d++) {
        REAL x = CK(errs[d] - mean);
        total = CK(total + CK(x * x));
    }
    total = CK(total / k);
    return flag ? mp_const_none : RNEW(total);
}
