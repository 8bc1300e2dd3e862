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
//     fitsums.survey(words, sx, sy, sz, st)     # a sample into device/survey.py's block
//     fitsums.correct(numbers, sx, sy, sz)      # ExactCorrection.correct's h_c, or None
//
// are the survey's exact |h_c|, block sums and h_c (hc.h), and
//
//     fitsums.line(buf, template, values)       # a block's event line into buf, or None
//
// its event lines (line.h).

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

#include "wide.h"     // mul32, accumulate, small_within

// a * b for b < 2^16
static inline uint64_t mul32x16(uint32_t a, uint32_t b) {
    #if defined(__ARM_ARCH_6M__)
    return ((uint64_t)((a >> 16) * b) << 16) + (a & 0xffff) * b;
    #else
    return (uint64_t)a * b;
    #endif
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

#include "hc.h"       // the survey's |h_c|, block sums and h_c: magnitude, survey, correct
#include "line.h"     // the survey's event lines: line

mp_obj_t mpy_init(mp_obj_fun_bc_t *self, size_t n_args, size_t n_kw, mp_obj_t *args) {
    MP_DYNRUNTIME_INIT_ENTRY
    mp_store_global(MP_QSTR_add, MP_OBJ_FROM_PTR(&add_obj));
    mp_store_global(MP_QSTR_magnitude, MP_OBJ_FROM_PTR(&magnitude_obj));
    mp_store_global(MP_QSTR_survey, MP_OBJ_FROM_PTR(&survey_obj));
    mp_store_global(MP_QSTR_correct, MP_OBJ_FROM_PTR(&correct_obj));
    mp_store_global(MP_QSTR_line, MP_OBJ_FROM_PTR(&line_obj));
    mp_store_global(MP_QSTR_SURVEY_LIMBS, MP_OBJ_NEW_SMALL_INT(SURVEY_LIMBS));
    mp_store_global(MP_QSTR_NUMBERS, MP_OBJ_NEW_SMALL_INT(NUMBERS));
    mp_store_global(MP_QSTR_WORDS, MP_OBJ_NEW_SMALL_INT(WORDS));
    mp_store_global(MP_QSTR_COUNT, MP_OBJ_NEW_SMALL_INT(COUNT));
    mp_store_global(MP_QSTR_LEFT, MP_OBJ_NEW_SMALL_INT(LEFT));
    MP_DYNRUNTIME_INIT_EXIT
}
