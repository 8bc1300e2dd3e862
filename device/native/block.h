#include "py/objlist.h"

// block.h: a survey block's numbers from fitsums.survey's words (included by fitsums.c, after hc.h):
//
//     st = fitsums.block(words, (numbers, n, d, restart), values)   # the t codes' sum, or None
//
// device/survey.py Output._numbers in machine words, for the block of n samples (d = n x window
// codes a sum) complete in `words` (hc.h's survey layout): into the list `values` (the data
// event's, device/protocol.py DATA_LINE's order) the mean codes in hundredths at 3-5 (protocol.py
// hundredths: s // d, the remainder rounded half up), h_c in milli-nT at 8-10 (correct()'s, with
// `numbers`: an ExactCorrection's for sums of d codes) and the mean |h_c| in milli-nT at 11 ((fs +
// 2^7 n) // (2^8 n), fs the |h_c| sum in 1/256 milli-nT); returns the sum of the t codes. With
// `restart` true the words then hold an empty block of n samples (Survey.restart's), else they are
// left as they are (for a second call with other numbers: the temperature's, survey.py). Three
// arguments, the fixed ones in a tuple: Output._block's frame stays within the 11 words
// MicroPython keeps off the heap (tests/test_frames.py).
// None, values untouched, where anything is past the words: a sum (|s| < 2^47, the x, y, z
// under hc.h's SUM_LIMIT for h_c), d of 2^22 or more, a result not a small int on every port
// (|v| < 2^30), `values` not a list of 12, the tuple not four: the caller then does it in Python. Nothing is
// allocated; the divisions are shifts and subtractions (no divide on a Cortex-M0+, none linked).

#define BLOCK_SUM_LIMIT ((int64_t)1 << 47)
#define D_LIMIT ((uint32_t)1 << 22)
#define SMALL_LIMIT ((int64_t)1 << 30)

// n / d and its remainder, d > 0: d shifted up under n, then one bit of the quotient a step
static uint64_t udiv64(uint64_t n, uint64_t d, uint64_t *rem) {
    uint64_t q = 0, bit = 1;
    while (d < n && !(d >> 63)) {
        d <<= 1;
        bit <<= 1;
    }
    for (; bit; d >>= 1, bit >>= 1) {
        if (n >= d) {
            n -= d;
            q |= bit;
        }
    }
    *rem = n;
    return q;
}

// s / d in hundredths as protocol.hundredths: q = floor(s / d), 100 q + (200 (s - q d) + d) // (2 d),
// into *c; false past a small int. |s| < 2^47, 0 < d < 2^22: q's magnitude is checked under 2^23
// first, so 100 q and 200 r + d (r < d) are 32-bit (a 64-bit multiply is not linked on armv6m)
static bool hundredths(int64_t s, uint32_t d, mp_int_t *c) {
    uint64_t r;
    uint64_t q = udiv64(s < 0 ? -(uint64_t)s : (uint64_t)s, d, &r);
    if (q >= ((uint64_t)1 << 23)) {
        return false;
    }
    int32_t qs = (int32_t)q;
    if (s < 0) {                    // floor: one lower where the division was not exact
        qs = -qs;
        if (r) {
            qs -= 1;
            r = d - r;
        }
    }
    uint64_t unused;
    int32_t v = 100 * qs + (int32_t)udiv64(200 * (uint32_t)r + d, 2 * (uint64_t)d, &unused);
    if (v >= SMALL_LIMIT || v < -SMALL_LIMIT) {
        return false;
    }
    *c = v;
    return true;
}

static mp_obj_t block(size_t n_args, const mp_obj_t *args) {
    mp_buffer_info_t bufinfo;
    mp_get_buffer_raise(args[0], &bufinfo, MP_BUFFER_RW);
    if (bufinfo.len < SURVEY_LIMBS * sizeof(uint16_t)) {
        mp_raise_ValueError(MP_ERROR_TEXT("fitsums: words holds fewer than SURVEY_LIMBS limbs"));
    }
    if (mp_obj_get_type(args[1]) != &mp_type_tuple || mp_obj_get_type(args[2]) != &mp_type_list) {
        return mp_const_none;
    }
    mp_obj_tuple_t *how = MP_OBJ_TO_PTR(args[1]);
    int64_t n, d;
    if (how->len != 4 || !small_within(how->items[1], 1 << 16, &n) || n <= 0 ||
        !small_within(how->items[2], D_LIMIT, &d) || d <= 0) {
        return mp_const_none;
    }
    const uint16_t *num = limbs(how->items[0]);
    mp_obj_list_t *values = MP_OBJ_TO_PTR(args[2]);
    if (values->len != 12) {
        return mp_const_none;
    }
    // the five sums x, y, z, t, |h_c|: 64-bit two's complements in 32-bit words, low first
    uint32_t *w = (uint32_t *)bufinfo.buf;
    int64_t s[5];
    for (int j = 0; j < 5; j++) {
        s[j] = (int64_t)(((uint64_t)w[2 * j + 1] << 32) | w[2 * j]);
        if (s[j] <= -BLOCK_SUM_LIMIT || s[j] >= BLOCK_SUM_LIMIT) {
            return mp_const_none;
        }
    }
    mp_int_t c[3], b[3];
    uint64_t f, unused;
    if (s[3] < -SMALL_LIMIT || s[3] >= SMALL_LIMIT || s[4] < 0 || !rounded(num, s, b)) {
        return mp_const_none;
    }
    for (int i = 0; i < 3; i++) {
        if (!hundredths(s[i], (uint32_t)d, &c[i])) {
            return mp_const_none;
        }
    }
    f = udiv64((uint64_t)s[4] + ((uint64_t)n << 7), (uint64_t)n << 8, &unused);
    if (f >= (uint64_t)SMALL_LIMIT) {
        return mp_const_none;
    }
    mp_obj_t *v = values->items;
    for (int i = 0; i < 3; i++) {
        v[3 + i] = MP_OBJ_NEW_SMALL_INT(c[i]);
        v[8 + i] = MP_OBJ_NEW_SMALL_INT(b[i]);
    }
    v[11] = MP_OBJ_NEW_SMALL_INT((mp_int_t)f);
    if (mp_obj_is_true(how->items[3])) {
        // the five sums zeroed word by word, written out: a loop may become a memset call, and a
        // native module links no libc
        w[0] = w[1] = w[2] = w[3] = w[4] = w[5] = w[6] = w[7] = w[8] = w[9] = 0;
        ((uint16_t *)w)[SURVEY_LEFT] = (uint16_t)n;
    }
    return MP_OBJ_NEW_SMALL_INT((mp_int_t)s[3]);
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(block_obj, 3, 3, block);
