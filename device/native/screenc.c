// screenc: the common path of the spike screen's push (device/screen.py) in C (a MicroPython
// native module, .mpy).
//
//     import screenc
//     sc.push = screenc.Push(sc, Screen.push)    # in Screen.__init__: sc.push(x, y, z, t) -> bool
//
// Screen.push is the reference, word for word. This does only its commonest case: a sample
// that is not clipped, with two samples held (n == 2), where half the largest bend of the held
// one is within spike_nt + allow (thr): it is good without the stand-out. Then it does what
// Screen.push does there: learns the pending bend into thr, holds the new pending bend, sets
// sc.x, .y, .z, .t (the held sample) and shifts the held samples, in the same list sc._st, and
// returns True. Any other push (clipped, after a reset, a possible spike), and any whose
// numbers are not small ints or do not fit the bounds below, goes to Screen.push(sc, x, y, z, t)
// before anything is written, so the result is the reference's.
//
// sc._k = (c, -c, sp, mx, sx, my, sy, mz, sz): the clip bound, spike_nt and each axis's
// multiplier m / 2**sh; sc._st = [ax, ay, az, cx, cy, cz, ct, n, thr, pending] (screen.py),
// taken once here: the screen never replaces them. The instance attribute push is found
// before the class's method, and calling it passes the four arguments on the C stack.
// Words: the codes and held sums within +-2^31 (a window of 24-bit codes: under 2^29), so a
// bend's sum difference is under 2^33 and, times m < 2^29, under 2^62; thr, pending and sp
// within +-2^60. A 32-bit port's small ints (under 2^30) always fit; the 64-bit ports' can
// exceed them, and those go to Python. What is stored back must be a small int (no heap: a
// push here allocates nothing), else Python does the push (exact, with its long ints).

#include "py/dynruntime.h"
#include "py/objlist.h"
#include "py/objtuple.h"
#include "py/smallint.h"
#include "words.h"

#define STATE (10)              // len(self._st)
#define CODE_LIMIT (((int64_t)1) << 31)
#define THR_LIMIT (((int64_t)1) << 60)
#define M_LIMIT (((int64_t)1) << 29)

// floor(v / 16), as Python's v >> 4 on a negative v too
static inline int64_t floor16(int64_t v) {
    return v >= 0 ? (int64_t)shr((uint64_t)v, 4) : -(int64_t)shr((uint64_t)(15 - v), 4);
}

// the bend on one axis in units: (|a - e| * m) >> sh
static inline int64_t bend(int64_t a, int64_t e, int64_t m, int64_t sh) {
    int64_t d = a - e;
    return (int64_t)shr(mul((uint64_t)(d > 0 ? d : -d), (uint32_t)m), (uint32_t)sh);
}

typedef struct {
    mp_obj_base_t base;
    mp_obj_t screen;
    mp_obj_t python_push;       // Screen.push, a function of (screen, x, y, z, t)
    mp_obj_t *st;               // screen._st's items
    const mp_obj_t *k;          // screen._k's
    mp_obj_t lists[2];          // _st and _k: held, so their items stay alive
} push_t;

mp_obj_full_type_t push_type;

// Push(screen, python_push)
static mp_obj_t push_make_new(const mp_obj_type_t *type, size_t n_args, size_t n_kw, const mp_obj_t *args) {
    mp_arg_check_num(n_args, n_kw, 2, 2, false);
    push_t *self = mp_obj_malloc(push_t, type);
    mp_obj_t st = mp_load_attr(args[0], MP_QSTR__st), k = mp_load_attr(args[0], MP_QSTR__k);
    if (!mp_obj_is_type(st, &mp_type_list) || ((mp_obj_list_t *)MP_OBJ_TO_PTR(st))->len != STATE
        || !mp_obj_is_type(k, &mp_type_tuple) || ((mp_obj_tuple_t *)MP_OBJ_TO_PTR(k))->len != 9) {
        mp_raise_TypeError(MP_ERROR_TEXT("screenc: _st is a list of 10, _k a tuple of 9"));
    }
    self->screen = args[0];
    self->python_push = args[1];
    self->st = ((mp_obj_list_t *)MP_OBJ_TO_PTR(st))->items;
    self->k = ((mp_obj_tuple_t *)MP_OBJ_TO_PTR(k))->items;
    self->lists[0] = st;
    self->lists[1] = k;
    return MP_OBJ_FROM_PTR(self);
}

// push(x, y, z, t)
static mp_obj_t push_call(mp_obj_t self_in, size_t n_args, size_t n_kw, const mp_obj_t *args) {
    if (n_args != 4 || n_kw) {
        mp_raise_TypeError(MP_ERROR_TEXT("screenc: push takes x, y, z, t"));
    }
    push_t *self = MP_OBJ_TO_PTR(self_in);
    mp_obj_t *st = self->st;
    const mp_obj_t *k = self->k;
    // the numbers, each a small int within its bound, or Python does the push
    int64_t v[3], c, sp, m[3], sh[3], held[6], thr, pend;
    bool ok = small(k[0], CODE_LIMIT, &c) && small(k[2], THR_LIMIT, &sp) && st[7] == MP_OBJ_NEW_SMALL_INT(2)
        && small(st[8], THR_LIMIT, &thr) && small(st[9], THR_LIMIT, &pend);
    for (int i = 0; ok && i < 3; i++) {
        ok = small(args[i], CODE_LIMIT, &v[i]) && v[i] < c && v[i] > -c       // not clipped
            && small(k[3 + 2 * i], M_LIMIT, &m[i]) && m[i] >= 0 && small(k[4 + 2 * i], 63, &sh[i]) && sh[i] >= 0
            && small(st[i], CODE_LIMIT, &held[i]) && small(st[3 + i], CODE_LIMIT, &held[3 + i]);
    }
    if (!ok) {
        return call_python(self->python_push, self->screen, args);
    }
    // the bend of c, |(c - p) - (n - c)| per axis in units, the largest: e
    int64_t d[3], e = 0;
    for (int i = 0; i < 3; i++) {
        d[i] = v[i] - held[3 + i];          // n - c
        int64_t b = bend(held[i], d[i], m[i], sh[i]);
        if (b > e) {
            e = b;
        }
    }
    // within spike_nt + allow by half the largest bend: good without the stand-out. Else
    // Python judges it (a spike, a sharp bend: _stands_out)
    if ((int64_t)shr((uint64_t)e, 1) > thr) {
        return call_python(self->python_push, self->screen, args);
    }
    // learn the pending bend (allow += (p - allow + 8) >> 4, on thr), hold this one's
    int64_t thr2 = pend >= 0 ? thr + floor16(pend + sp - thr + 8) : thr;
    if (!fits(thr2) || !fits(e + e) || !fits(d[0]) || !fits(d[1]) || !fits(d[2])) {
        return call_python(self->python_push, self->screen, args);
    }
    st[8] = MP_OBJ_NEW_SMALL_INT((mp_int_t)thr2);
    st[9] = MP_OBJ_NEW_SMALL_INT((mp_int_t)(e + e));
    mp_obj_t sc = self->screen;
    mp_store_attr(sc, MP_QSTR_x, st[3]);      // the held sample is good
    mp_store_attr(sc, MP_QSTR_y, st[4]);
    mp_store_attr(sc, MP_QSTR_z, st[5]);
    mp_store_attr(sc, MP_QSTR_t, st[6]);
    for (int i = 0; i < 3; i++) {
        st[i] = MP_OBJ_NEW_SMALL_INT((mp_int_t)d[i]);
        st[3 + i] = args[i];
    }
    st[6] = args[3];
    return mp_const_true;
}

mp_obj_t mpy_init(mp_obj_fun_bc_t *self, size_t n_args, size_t n_kw, mp_obj_t *args) {
    MP_DYNRUNTIME_INIT_ENTRY
    push_type.base.type = (void *)&mp_type_type;
    push_type.flags = MP_TYPE_FLAG_NONE;
    push_type.name = MP_QSTR_Push;
    MP_OBJ_TYPE_SET_SLOT(&push_type, make_new, push_make_new, 0);
    MP_OBJ_TYPE_SET_SLOT(&push_type, call, push_call, 1);
    mp_store_global(MP_QSTR_Push, MP_OBJ_FROM_PTR(&push_type));
    MP_DYNRUNTIME_INIT_EXIT
}
