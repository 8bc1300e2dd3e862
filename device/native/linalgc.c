// linalgc: shared/linalg.py's cholesky, cho_solve, solve_spd and eigh3 in C (a MicroPython native
// module, .mpy), and the normal equations' float work (shared/quadric.py's normal_matrix,
// shared/iteration.py's add_prior, shared/prior.py's residuals: solver_body.h) and the predicted
// error's (shared/predicted.py's _sphere_gradients, _variance_sum, _bias_spread: predicted_body.h), for the solver's float work on a board
// (shared/solver.py: the step direction, the initial guesses, the predicted error; on an RP2040
// every float operation in bytecode is a heap allocation).
//
//     import linalgc
//     linalgc.kind()                 # "f", "d": the interpreter's floats, which this build matches; None
//     linalgc.cholesky(a)            # L (lists), or None
//     linalgc.cho_solve(low, b)      # x, or None
//     linalgc.solve_spd(a, b)        # x, or None
//     linalgc.eigh3(s)               # (values, vectors), or None
//     linalgc.normal_matrix(mean, am, nf, tables)   # shared/quadric.py's H, or None
//     linalgc.add_prior(h, g, rho, jac, lam)        # shared/iteration.py's, in place: True, or None
//     linalgc.prior_residuals(prior, a, f)          # shared/prior.py's Prior.residuals: (rho, jac), or None
//     linalgc.sphere_gradients(values, vectors, am, ico)  # shared/predicted.py's three (all directions),
//     linalgc.variance_sum(low, grads)                    # each a float result or None
//     linalgc.bias_spread(grads, bias, centred)
//     linalgc.to_float(x, exponent)  # shared/moments.py's to_float by the interpreter's own operations
//     linalgc.exact_words(sums)             # the 35 power sums as words (a bytearray), or None
//     linalgc.recentre(words, c, chains)    # moments.recentred: the 35 ints, then their words; or None
//     linalgc.exact(words, a_int, tables, f3)   # quadric's Problem.exact: (g_A, T, RSS), or None (exact_body.h)
//     linalgc.exact_ints(words[, indices])  # the 35 ints of the words (those at indices)
//     linalgc.frame_floats(words, indices, degrees, frac)   # quadric.frame_means's floats, or None
//     linalgc.scaled_words(words, bits, degrees)            # moments.scaled by 2**bits, as recentre's
//
// Word for word shared/linalg.py's, in the interpreter's own float: the same operations in the same
// order, each rounded once as MicroPython rounds it (IEEE 754 binary32 or binary64, round to nearest
// even; no fused multiply-add: -ffp-contract=off; sqrt correctly rounded on both sides: the Pico's
// math.sqrt is lib/libm's ef_sqrt.c, this module's newlib's sqrtf, the same fdlibm algorithm, and on
// x64 the sqrtss/sqrtsd instructions). kind() says which: a build has binary32 ("f", every
// architecture) and binary64 ("d", x64 only); a 30-bit float (micropython-reprc, its last two bits
// cut at every operation) or an x87 build (x86) matches neither, and None sends every call to Python.
// None too for any input the Python might treat otherwise (not a list of lists of floats, a size past
// N_MAX, an infinity or nan) and for what Python raises on (a pivot not positive, a zero divisor):
// shared/linalg.py then runs its own code, which raises or returns as it always did.

#include "py/dynruntime.h"

#define N_MAX (12)

// (not static: mpy_ld places no static variable in bss)
const mp_obj_type_t *float_type;
int kind_in_use;
bool flush_subnormals;      // the interpreter's float operations flush subnormal results to zero

// n from a list or tuple (its items in *items), or 0
static inline size_t items_of(mp_obj_t o, mp_obj_t **items) {
    const mp_obj_type_t *t = mp_obj_get_type(o);
    if (t != &mp_type_list && t != &mp_type_tuple) {
        return 0;
    }
    size_t n;
    mp_obj_get_array_dyn(o, &n, items);
    return n <= N_MAX ? n : 0;
}

#include "exact_body.h"      // the exact integer work in words (the float bodies read sums from them)
extern mp_obj_t ldexp_fn;   // math.ldexp (below)

#if defined(__i386__)
#define HAS_FLOAT (0)       // x87: a float held in 80 bits between operations (kind() None)
#else
#define HAS_FLOAT (1)
#if defined(__arm__)
float __ieee754_sqrtf(float);   // newlib's ef_sqrt.c itself: its sqrtf wrapper brings errno's data along
#define RSQRT(x) __ieee754_sqrtf(x)
#else
#define RSQRT(x) __builtin_sqrtf(x)
#endif
#define REAL float
#define RUINT uint32_t
#define RNAME(name) name##_f
#define RABS(x) __builtin_fabsf(x)
#define RGET(o) mp_obj_get_float_to_f(o)
#define RNEW(x) mp_obj_new_float_from_f(x)
#include "linalg_body.h"
#include "solver_body.h"
#include "predicted_body.h"
#undef REAL
#undef RUINT
#undef RSIGN
#undef RNAME
#undef RSQRT
#undef RABS
#undef RGET
#undef RNEW
#endif

#if defined(__x86_64__)
#define HAS_DOUBLE (1)
#define REAL double
#define RUINT uint64_t
#define RNAME(name) name##_d
#define RSQRT(x) __builtin_sqrt(x)
#define RABS(x) __builtin_fabs(x)
#define RGET(o) mp_obj_get_float_to_d(o)
#define RNEW(x) mp_obj_new_float_from_d(x)
#include "linalg_body.h"
#include "solver_body.h"
#include "predicted_body.h"
#else
#define HAS_DOUBLE (0)
#endif

// the interpreter's float: 'd' binary64, 'f' binary32 (all of its 24 bits kept), else 0; bits
// compared as integers, so no double arithmetic is linked where there is none (armv6m)
static int interpreter_kind(void) {
    union { double d; uint64_t u; } in, out;
    in.d = 1.0 + 0x1p-40;
    out.d = mp_obj_get_float_to_d(mp_obj_new_float_from_d(in.d));
    if (out.u == in.u) {
        return 'd';
    }
    union { float f; uint32_t u; } fin, fout;
    fin.f = 1.0f + 0x1p-23f;
    fout.f = mp_obj_get_float_to_f(mp_obj_new_float_from_f(fin.f));
    return fout.u == fin.u ? 'f' : 0;
}

// whether the interpreter's own float operations flush a subnormal result to zero (the RP2040's ROM
// floats) or keep it (IEEE 754's gradual underflow), asked of its multiply and subtract: None where
// they disagree, or a kernel's results could not be the interpreter's
static int interpreter_subnormals(void) {
    union { float f; uint32_t u; } a, b, p, d;
    a.f = 0x1p-70f;
    b.f = 0x1.8p-126f;
    p.f = mp_obj_get_float_to_f(mp_binary_op(MP_BINARY_OP_MULTIPLY, mp_obj_new_float_from_f(a.f), mp_obj_new_float_from_f(a.f)));
    d.f = mp_obj_get_float_to_f(mp_binary_op(MP_BINARY_OP_SUBTRACT, mp_obj_new_float_from_f(b.f), mp_obj_new_float_from_f(0x1p-126f)));
    if (p.u == 0 && d.u == 0) {
        return 1;       // flushed
    }
    return p.u == 0x00000200u && d.u == 0x00400000u ? 0 : -1;    // 2^-140 and 2^-127 kept
}

static mp_obj_t kind(void) {
    if (kind_in_use == 'd') {
        return MP_OBJ_NEW_QSTR(MP_QSTR_d);
    }
    return kind_in_use == 'f' ? MP_OBJ_NEW_QSTR(MP_QSTR_f) : mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_0(kind_obj, kind);

// the kernels of the float in use, or None; a build without one of the two types answers None for it
#if !HAS_FLOAT
#define cholesky_f(...) mp_const_none
#define cho_solve_f(...) mp_const_none
#define solve_spd_f(...) mp_const_none
#define eigh3_f(...) mp_const_none
#define normal_matrix_f(...) mp_const_none
#define add_prior_f(...) mp_const_none
#define prior_residuals_f(...) mp_const_none
#define sphere_gradients_f(...) mp_const_none
#define variance_sum_f(...) mp_const_none
#define bias_spread_f(...) mp_const_none
#define frame_floats_f(...) mp_const_none
#endif
#if !HAS_DOUBLE
#define cholesky_d(...) mp_const_none
#define cho_solve_d(...) mp_const_none
#define solve_spd_d(...) mp_const_none
#define eigh3_d(...) mp_const_none
#define normal_matrix_d(...) mp_const_none
#define add_prior_d(...) mp_const_none
#define prior_residuals_d(...) mp_const_none
#define sphere_gradients_d(...) mp_const_none
#define variance_sum_d(...) mp_const_none
#define bias_spread_d(...) mp_const_none
#define frame_floats_d(...) mp_const_none
#endif
#define IN_USE(name, ...) (kind_in_use == 'd' ? name##_d(__VA_ARGS__) : kind_in_use == 'f' ? name##_f(__VA_ARGS__) : mp_const_none)

static mp_obj_t cholesky(mp_obj_t a) {
    return IN_USE(cholesky, a);
}
static MP_DEFINE_CONST_FUN_OBJ_1(cholesky_obj, cholesky);

static mp_obj_t cho_solve(mp_obj_t low, mp_obj_t b) {
    return IN_USE(cho_solve, low, b);
}
static MP_DEFINE_CONST_FUN_OBJ_2(cho_solve_obj, cho_solve);

static mp_obj_t solve_spd(mp_obj_t a, mp_obj_t b) {
    return IN_USE(solve_spd, a, b);
}
static MP_DEFINE_CONST_FUN_OBJ_2(solve_spd_obj, solve_spd);

static mp_obj_t eigh3(mp_obj_t s) {
    return IN_USE(eigh3, s);
}
static MP_DEFINE_CONST_FUN_OBJ_1(eigh3_obj, eigh3);

static mp_obj_t normal_matrix(size_t n_args, const mp_obj_t *args) {
    return IN_USE(normal_matrix, args[0], args[1], args[2], args[3]);
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(normal_matrix_obj, 4, 4, normal_matrix);

static mp_obj_t add_prior(size_t n_args, const mp_obj_t *args) {
    return IN_USE(add_prior, n_args, args);
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(add_prior_obj, 5, 5, add_prior);

static mp_obj_t prior_residuals(mp_obj_t self, mp_obj_t a, mp_obj_t f) {
    // (the names here: mpy_ld collects a module's qstrs from its .c file, not from the headers)
    if (!kind_in_use) {
        return mp_const_none;
    }
    mp_obj_t attrs[7] = {
        mp_load_attr(self, MP_QSTR_kr), mp_load_attr(self, MP_QSTR_q_target), mp_load_attr(self, MP_QSTR_q_sigma),
        mp_load_attr(self, MP_QSTR_f_target), mp_load_attr(self, MP_QSTR_f_sigma),
        mp_load_attr(self, MP_QSTR_t_target), mp_load_attr(self, MP_QSTR_t_sigma),
    };
    (void)attrs;    // (a build without the float in use: the macro below does not read them)
    return IN_USE(prior_residuals, attrs, a, f);
}
static MP_DEFINE_CONST_FUN_OBJ_3(prior_residuals_obj, prior_residuals);

static mp_obj_t sphere_gradients(size_t n_args, const mp_obj_t *args) {
    return IN_USE(sphere_gradients, n_args, args);
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(sphere_gradients_obj, 4, 4, sphere_gradients);

static mp_obj_t variance_sum(mp_obj_t low, mp_obj_t grads) {
    return IN_USE(variance_sum, low, grads);
}
static MP_DEFINE_CONST_FUN_OBJ_2(variance_sum_obj, variance_sum);

static mp_obj_t bias_spread(mp_obj_t grads, mp_obj_t bias, mp_obj_t centred) {
    return IN_USE(bias_spread, grads, bias, centred);
}
static MP_DEFINE_CONST_FUN_OBJ_3(bias_spread_obj, bias_spread);

// to_float: shared/moments.py's to_float by the interpreter's own int and float operations (no
// arithmetic of its own, so the same on every port): the bit length found by comparisons with powers
// of two made once (moments.bit_length shifts at each step, and on a board each shift is a heap
// allocation), then its shift, float() and math.ldexp, without a bytecode frame and a call for each.
// A Pico converts some hundred sums a solve, ~130 us each in bytecode. (Not static: mpy_ld places no
// static variable in bss.)
#define N_POWERS (20)           // 2**16 .. 2**320: a solve's sums are under 2**260
mp_obj_t float_fn, ldexp_fn;
mp_obj_t powers[N_POWERS + 1];  // powers[j] = 2**(16 j), j >= 1
const mp_obj_type_t *int_type;

static inline bool at_least(mp_obj_t x, mp_obj_t y) {
    return mp_binary_op(MP_BINARY_OP_MORE_EQUAL, x, y) == mp_const_true;
}

// the number of bits of |x| for an int x (moments.bit_length)
static mp_int_t int_bits(mp_obj_t x) {
    if (!mp_obj_is_small_int(x) && mp_binary_op(MP_BINARY_OP_LESS, x, MP_OBJ_NEW_SMALL_INT(0)) == mp_const_true) {
        x = mp_unary_op(MP_UNARY_OP_NEGATIVE, x);
    }
    mp_int_t n = 0;
    if (!mp_obj_is_small_int(x)) {
        while (at_least(x, powers[N_POWERS])) {
            x = mp_binary_op(MP_BINARY_OP_RSHIFT, x, MP_OBJ_NEW_SMALL_INT(16 * N_POWERS));
            n += 16 * N_POWERS;
        }
        size_t lo = 0, hi = N_POWERS;       // 2**(16 lo) <= x < 2**(16 hi), powers[0] standing for 1
        while (hi - lo > 1) {
            size_t mid = (lo + hi) / 2;
            if (at_least(x, powers[mid])) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        if (lo) {
            x = mp_binary_op(MP_BINARY_OP_RSHIFT, x, MP_OBJ_NEW_SMALL_INT(16 * lo));
            n += 16 * lo;
        }
    }
    mp_int_t v = MP_OBJ_SMALL_INT_VALUE(x);
    for (mp_uint_t u = v < 0 ? -(mp_uint_t)v : (mp_uint_t)v; u; u >>= 1) {
        n++;
    }
    return n;
}

// to_float(x, exponent=0): float(x * 2**exponent) as moments.to_float makes it
static mp_obj_t to_float(size_t n_args, const mp_obj_t *args) {
    mp_obj_t x = args[0], e = n_args > 1 ? args[1] : MP_OBJ_NEW_SMALL_INT(0);
    if (x == mp_const_false || x == mp_const_true) {
        x = MP_OBJ_NEW_SMALL_INT(x == mp_const_true);      // an int in Python too
    }
    if ((!mp_obj_is_small_int(x) && mp_obj_get_type(x) != int_type) || !mp_obj_is_small_int(e)) {
        mp_raise_TypeError(MP_ERROR_TEXT("to_float takes an int"));       // as the Python's shifts would
    }
    mp_int_t exponent = MP_OBJ_SMALL_INT_VALUE(e), extra = int_bits(x) - 53;
    if (extra > 0) {
        x = mp_binary_op(MP_BINARY_OP_RSHIFT, x, MP_OBJ_NEW_SMALL_INT(extra));
        exponent += extra;
    }
    mp_obj_t call[2] = {mp_call_function_n_kw(float_fn, 1, 0, &x), MP_OBJ_NEW_SMALL_INT(exponent)};
    return mp_call_function_n_kw(ldexp_fn, 2, 0, call);
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(to_float_obj, 1, 2, to_float);

#include "exact_objects.h"

mp_obj_t mpy_init(mp_obj_fun_bc_t *self, size_t n_args, size_t n_kw, mp_obj_t *args) {
    MP_DYNRUNTIME_INIT_ENTRY
    float_type = mp_obj_get_type(mp_obj_new_float_from_f(0.0f));
    kind_in_use = interpreter_kind();
    int subnormals = kind_in_use == 'f' ? interpreter_subnormals() : 0;
    flush_subnormals = subnormals == 1;
    if (subnormals < 0) {
        kind_in_use = 0;
    }
    if ((kind_in_use == 'd' && !HAS_DOUBLE) || (kind_in_use == 'f' && !HAS_FLOAT)) {
        kind_in_use = 0;
    }
    float_fn = mp_load_global(MP_QSTR_float);
    ldexp_fn = mp_load_attr(mp_import_name(MP_QSTR_math, mp_const_none, MP_OBJ_NEW_SMALL_INT(0)), MP_QSTR_ldexp);
    powers[0] = MP_OBJ_NEW_SMALL_INT(1);
    for (size_t j = 1; j <= N_POWERS; j++) {
        powers[j] = mp_binary_op(MP_BINARY_OP_LSHIFT, MP_OBJ_NEW_SMALL_INT(1), MP_OBJ_NEW_SMALL_INT(16 * j));
    }
    int_type = mp_obj_get_type(powers[N_POWERS]);
    // (heap objects: the module's dict keeps them for the collector)
    mp_store_global(MP_QSTR__POWERS, mp_obj_new_tuple(N_POWERS + 1, powers));
    mp_store_global(MP_QSTR_to_float, MP_OBJ_FROM_PTR(&to_float_obj));
    // exact_body.h's: int.from_bytes and int.to_bytes (the functions themselves: no bound method kept)
    mp_obj_t dest[2];
    mp_load_method(MP_OBJ_FROM_PTR(int_type), MP_QSTR_from_bytes, dest);
    e_from_bytes = dest[0];
    mp_load_method(MP_OBJ_NEW_SMALL_INT(0), MP_QSTR_to_bytes, dest);
    e_to_bytes = dest[0];
    e_little = MP_OBJ_NEW_QSTR(MP_QSTR_little);
    e_bytearray = mp_load_global(MP_QSTR_bytearray);
    e_limits[1] = mp_binary_op(MP_BINARY_OP_LSHIFT, MP_OBJ_NEW_SMALL_INT(1), MP_OBJ_NEW_SMALL_INT(EBITS));
    e_limits[0] = mp_unary_op(MP_UNARY_OP_NEGATIVE, e_limits[1]);
    mp_store_global(MP_QSTR__EXACT, mp_obj_new_tuple(2, e_limits));
    mp_store_global(MP_QSTR_exact_words, MP_OBJ_FROM_PTR(&exact_words_obj));
    mp_store_global(MP_QSTR_recentre, MP_OBJ_FROM_PTR(&recentre_obj));
    mp_store_global(MP_QSTR_exact, MP_OBJ_FROM_PTR(&exact_obj));
    mp_store_global(MP_QSTR_exact_ints, MP_OBJ_FROM_PTR(&exact_ints_obj));
    mp_store_global(MP_QSTR_frame_floats, MP_OBJ_FROM_PTR(&frame_floats_obj));
    mp_store_global(MP_QSTR_scaled_words, MP_OBJ_FROM_PTR(&scaled_words_obj));
    mp_store_global(MP_QSTR_kind, MP_OBJ_FROM_PTR(&kind_obj));
    mp_store_global(MP_QSTR_cholesky, MP_OBJ_FROM_PTR(&cholesky_obj));
    mp_store_global(MP_QSTR_cho_solve, MP_OBJ_FROM_PTR(&cho_solve_obj));
    mp_store_global(MP_QSTR_solve_spd, MP_OBJ_FROM_PTR(&solve_spd_obj));
    mp_store_global(MP_QSTR_eigh3, MP_OBJ_FROM_PTR(&eigh3_obj));
    mp_store_global(MP_QSTR_normal_matrix, MP_OBJ_FROM_PTR(&normal_matrix_obj));
    mp_store_global(MP_QSTR_add_prior, MP_OBJ_FROM_PTR(&add_prior_obj));
    mp_store_global(MP_QSTR_prior_residuals, MP_OBJ_FROM_PTR(&prior_residuals_obj));
    mp_store_global(MP_QSTR_sphere_gradients, MP_OBJ_FROM_PTR(&sphere_gradients_obj));
    mp_store_global(MP_QSTR_variance_sum, MP_OBJ_FROM_PTR(&variance_sum_obj));
    mp_store_global(MP_QSTR_bias_spread, MP_OBJ_FROM_PTR(&bias_spread_obj));
    MP_DYNRUNTIME_INIT_EXIT
}
