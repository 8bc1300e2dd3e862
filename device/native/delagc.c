// delagc: the common path of the de-lag's push (shared/delag.py) in C (a MicroPython native
// module, .mpy).
//
//     import delagc
//     dl.push = delagc.Push(dl, Delag.push)     # in Delag.set_taus: dl.push(x, y, z, t) -> bool
//
// Delag.push is the reference, word for word. This does its common case, five samples held
// (_n >= 4): the same rotation of the same lists (_h), the three de-lagged terms (_delagged:
// the same floors and ties), the saturation count, .x .y .z .t, and with _dk the tau steps'
// terms .ex .ey .ez. Any push with _n < 4, and any whose numbers are not small ints or pass
// the bounds below, goes to Delag.push(dl, x, y, z, t) before anything is written.
//
// Taken once here (set_taus makes a new Push after setting them): _h, _k, _lim (3 limits, 6
// with steps), _dk (a list or None), _shift and top; _n and saturated are read at each push.
// Words: the sums within +-2^31 (a window of 64 24-bit codes: under 2^29), so a difference is
// under 2^32; num < 2^27 (8 num < 2^30, as coefficients() makes it), lim <= 2^28, 1 <= shift
// <= 16, top < 2^40: every product and sum below stays under 2^61. What is stored must be a
// small int (no heap: a push here allocates nothing), else Python does the push.

#include "py/dynruntime.h"
#include "py/objlist.h"
#include "py/smallint.h"
#include "words.h"

#define CODE_LIMIT (((int64_t)1) << 31)
#define NUM_LIMIT (((int64_t)1) << 27)
#define LIM_LIMIT ((((int64_t)1) << 28) + 1)
#define TOP_LIMIT (((int64_t)1) << 40)

// a * b signed, |a| < 2^34, 0 <= b < 2^30
static inline int64_t smul(int64_t a, uint32_t b) {
    return a >= 0 ? (int64_t)mul((uint64_t)a, b) : -(int64_t)mul((uint64_t)-a, b);
}

// floor(v / 2^s), as Python's v >> s on a negative v too (0 < s < 32)
static inline int64_t floorshr(int64_t v, uint32_t s) {
    return v >= 0 ? (int64_t)shr((uint64_t)v, s) : -(int64_t)shr((uint64_t)(-v - 1), s) - 1;
}

// a small int within +-limit (limit <= 2^31) in a machine word: on a 32-bit port every small
// int is (under 2^30), so only the 64-bit ports compare (64-bit compares cost on the M0+)
static inline bool word(mp_obj_t o, int64_t limit, mp_int_t *out) {
    if (!mp_obj_is_small_int(o)) {
        return false;
    }
    *out = MP_OBJ_SMALL_INT_VALUE(o);
    return sizeof(mp_int_t) <= 4 || (*out < limit && *out > -limit);
}

// the exact type, not mp_obj_is_type: in a native module that one's checks of its argument (not
// bool, int, str or None) are calls through the runtime's table, one a global lookup of `int`
// (py/obj.h, py/dynruntime.h): ~1.3 k cycles a call on the RP2040, five calls a push
static inline bool is_list(mp_obj_t o, size_t len) {
    return mp_obj_is_exact_type(o, &mp_type_list) && ((mp_obj_list_t *)MP_OBJ_TO_PTR(o))->len == len;
}

static inline mp_obj_t *items(mp_obj_t list) {
    return ((mp_obj_list_t *)MP_OBJ_TO_PTR(list))->items;
}

// _delagged(c, d1, d2, num, lim, shift, top): false for None (a term beyond the limits)
static bool delagged(int64_t c, int64_t d1, int64_t d2, int64_t num, int64_t lim, uint32_t shift,
    int64_t top, int64_t *out) {
    int64_t h1 = floorshr(d1, shift), h2 = floorshr(d2, shift);
    if (h1 > lim || h1 < -lim || h2 > 8 * lim || h2 < -8 * lim) {
        return false;
    }
    // d - (h << shift): d's low bits, 0 .. mask (two's complement; shifts of 32-bit words only)
    uint32_t mask = (1u << shift) - 1, n8 = (uint32_t)num << 3, n = (uint32_t)num;
    int64_t low = smul((uint32_t)d1 & mask, n8) - smul((uint32_t)d2 & mask, n) + (int64_t)(1u << (shift - 1));
    int64_t v = c + smul(h1, n8) - smul(h2, n) + floorshr(low, shift);
    if (v >= top || v <= -top) {
        return false;
    }
    *out = v;
    return true;
}

typedef struct {
    mp_obj_base_t base;
    mp_obj_t delag;
    mp_obj_t python_push;       // Delag.push, a function of (delag, x, y, z, t)
    mp_obj_t h, k, lim, dk;     // the lists _h, _k, _lim, _dk (dk: None, no steps)
    mp_obj_t shift, top;
} push_t;

mp_obj_full_type_t push_type;

// Push(delag, python_push)
static mp_obj_t push_make_new(const mp_obj_type_t *type, size_t n_args, size_t n_kw, const mp_obj_t *args) {
    mp_arg_check_num(n_args, n_kw, 2, 2, false);
    push_t *self = mp_obj_malloc(push_t, type);
    mp_obj_t dl = args[0];
    self->delag = dl;
    self->python_push = args[1];
    self->h = mp_load_attr(dl, MP_QSTR__h);
    self->k = mp_load_attr(dl, MP_QSTR__k);
    self->lim = mp_load_attr(dl, MP_QSTR__lim);
    self->dk = mp_load_attr(dl, MP_QSTR__dk);
    self->shift = mp_load_attr(dl, MP_QSTR__shift);
    self->top = mp_load_attr(dl, MP_QSTR_top);
    bool steps = self->dk != mp_const_none;
    if (!is_list(self->h, 5) || !is_list(self->k, 3) || !is_list(self->lim, steps ? 6 : 3)
        || (steps && !is_list(self->dk, 3))) {
        mp_raise_TypeError(MP_ERROR_TEXT("delagc: _h a list of 5, _k of 3, _dk of 3 or None, _lim of 6 or 3"));
    }
    return MP_OBJ_FROM_PTR(self);
}

// push(x, y, z, t)
static mp_obj_t push_call(mp_obj_t self_in, size_t n_args, size_t n_kw, const mp_obj_t *args) {
    if (n_args != 4 || n_kw) {
        mp_raise_TypeError(MP_ERROR_TEXT("delagc: push takes x, y, z, t"));
    }
    push_t *self = MP_OBJ_TO_PTR(self_in);
    mp_obj_t *h = items(self->h);
    int64_t top = 0;
    mp_int_t n = 0, shift = 1, v[3], old[4][3], k[3], lim[6], dk[3];
    bool steps = self->dk != mp_const_none;
    bool ok = word(mp_load_attr(self->delag, MP_QSTR__n), CODE_LIMIT, &n) && n >= 4
        && word(self->shift, 17, &shift) && shift >= 1 && shift <= 16 && small(self->top, TOP_LIMIT, &top);
    // the held samples oldest first: h[0] (its slot takes this one), h[1] .. h[4] (a .. d)
    for (int j = 0; ok && j < 5; j++) {
        ok = is_list(h[j], 4);
    }
    for (int i = 0; ok && i < 3; i++) {
        ok = word(args[i], CODE_LIMIT, &v[i]) && word(items(self->k)[i], NUM_LIMIT, &k[i])
            && k[i] >= 0 && k[i] < NUM_LIMIT && word(items(self->lim)[i], LIM_LIMIT, &lim[i]) && lim[i] < LIM_LIMIT
            && (!steps || (word(items(self->dk)[i], NUM_LIMIT, &dk[i]) && dk[i] >= 0 && dk[i] < NUM_LIMIT
                           && word(items(self->lim)[3 + i], LIM_LIMIT, &lim[3 + i]) && lim[3 + i] < LIM_LIMIT));
        for (int j = 0; ok && j < 4; j++) {
            ok = word(items(h[j + 1])[i], CODE_LIMIT, &old[j][i]);
        }
    }
    if (!ok) {
        return call_python(self->python_push, self->delag, args);
    }
    // a = old[0], b = old[1], c = old[2], d = old[3]; x = v: d1 = d - b, d2 = x - a
    int64_t out[3], e[3];
    bool good = true;
    for (int i = 0; i < 3; i++) {
        int64_t d1 = (int64_t)old[3][i] - old[1][i], d2 = (int64_t)v[i] - old[0][i];
        good = delagged(old[2][i], d1, d2, k[i], lim[i], (uint32_t)shift, top, &out[i]) && good;
        if (steps && good && !delagged(0, d1, d2, dk[i], lim[3 + i], (uint32_t)shift, top, &e[i])) {
            // a step's term beyond the limits: None, as Python has it
            return call_python(self->python_push, self->delag, args);
        }
    }
    mp_obj_t sat = MP_OBJ_NULL;
    if (!good) {
        int64_t s;
        if (!small(mp_load_attr(self->delag, MP_QSTR_saturated), CODE_LIMIT, &s) || !fits(s + 1)) {
            return call_python(self->python_push, self->delag, args);
        }
        sat = MP_OBJ_NEW_SMALL_INT((mp_int_t)(s + 1));
    } else if (!fits(out[0]) || !fits(out[1]) || !fits(out[2])) {
        return call_python(self->python_push, self->delag, args);
    }
    // the rotation: the oldest slot takes the newest sample (no allocation)
    mp_obj_t slot = h[0];
    h[0] = h[1];
    h[1] = h[2];
    h[2] = h[3];
    h[3] = h[4];
    h[4] = slot;
    mp_obj_t *s = items(slot);
    s[0] = args[0];
    s[1] = args[1];
    s[2] = args[2];
    s[3] = args[3];
    mp_obj_t dl = self->delag;
    if (!good) {
        mp_store_attr(dl, MP_QSTR_saturated, sat);
        return mp_const_false;
    }
    if (steps) {
        mp_store_attr(dl, MP_QSTR_ex, MP_OBJ_NEW_SMALL_INT((mp_int_t)e[0]));
        mp_store_attr(dl, MP_QSTR_ey, MP_OBJ_NEW_SMALL_INT((mp_int_t)e[1]));
        mp_store_attr(dl, MP_QSTR_ez, MP_OBJ_NEW_SMALL_INT((mp_int_t)e[2]));
    }
    mp_store_attr(dl, MP_QSTR_x, MP_OBJ_NEW_SMALL_INT((mp_int_t)out[0]));
    mp_store_attr(dl, MP_QSTR_y, MP_OBJ_NEW_SMALL_INT((mp_int_t)out[1]));
    mp_store_attr(dl, MP_QSTR_z, MP_OBJ_NEW_SMALL_INT((mp_int_t)out[2]));
    mp_store_attr(dl, MP_QSTR_t, items(h[2])[3]);       // c's temperature (h[2] after the rotation)
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
