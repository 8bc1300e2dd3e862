// fitsums: the 34 power sums x^i y^j z^k (1 <= i+j+k <= 4) of shared.fit.EllipsoidFit,
// summed in machine words (a MicroPython native module, .mpy).
//
//     import fitsums
//     acc = array.array("I", [0] * fitsums.WORDS)     # 34 sums x 4 words, zeroed
//     fitsums.add(acc, x, y, z, False)     # True: the sample is removed instead
//
// Each sum is a 128-bit two's-complement integer in four 32-bit words, least
// significant first, at acc[4*(n-1) .. 4*n-1] for storage index n (shared.moments.ORDER;
// index 0, the count, stays in Python). Sums are exact modulo 2^128, so they are exact
// whenever the true sum fits in 127 bits and a sign: with |v| < 2^24 each monomial is
// under 2^96 in magnitude, and shared.fit drains the words into its Python integers
// before 2^24 samples have been added or removed (2^24 * 2^96 = 2^120).
//
// add() returns False, touching nothing, for an argument that is not a small int or
// whose magnitude is 2^24 or more: the caller then takes the pure-Python path (which
// also raises the error for a float). MicroPython's small ints have the same tag on
// every object representation, so one build serves an architecture.

#include "py/dynruntime.h"

#define SUMS (34)
#define WORDS (4 * SUMS)
#define LIMIT (1 << 24)

// storage order (shared.moments.ORDER) as products of two factors from
// F = [1, x, y, z, xx, xy, xz, yy, yz, zz]: degree 1 = v * 1, 2 = v * v,
// 3 = (degree 2) * v, 4 = (degree 2) * (degree 2)
static const uint8_t FACTORS[SUMS][2] = {
    {1, 0}, {2, 0}, {3, 0},                                              // x y z
    {1, 1}, {1, 2}, {1, 3}, {2, 2}, {2, 3}, {3, 3},                      // xx xy xz yy yz zz
    {4, 1}, {4, 2}, {4, 3}, {7, 1}, {5, 3}, {9, 1},                      // xxx xxy xxz xyy xyz xzz
    {7, 2}, {7, 3}, {9, 2}, {9, 3},                                      // yyy yyz yzz zzz
    {4, 4}, {4, 5}, {4, 6}, {4, 7}, {4, 8}, {4, 9},                      // x^4 x3y x3z x2y2 x2yz x2z2
    {5, 7}, {5, 8}, {5, 9}, {6, 9},                                      // xy3 xy2z xyz2 xz3
    {7, 7}, {7, 8}, {7, 9}, {8, 9}, {9, 9},                              // y^4 y3z y2z2 yz3 z^4
};

// a * b in 64 bits: the Cortex-M0+ multiplies 32 x 32 -> 32 only, and libgcc's
// 64-bit multiply is not linked into a native module, so four 16-bit products there
static inline uint64_t mul32(uint32_t a, uint32_t b) {
    #if defined(__ARM_ARCH_6M__)
    uint32_t al = a & 0xffff, ah = a >> 16, bl = b & 0xffff, bh = b >> 16;
    uint64_t mid = (uint64_t)(al * bh) + (ah * bl);
    return ((uint64_t)(ah * bh) << 32) + (mid << 16) + al * bl;
    #else
    return (uint64_t)a * b;
    #endif
}

// a * b for |a|, |b| < 2^32, by magnitudes (no 64-bit multiply, as above)
static inline int64_t smul32(int64_t a, int64_t b) {
    uint64_t m = mul32((uint32_t)(a < 0 ? -a : a), (uint32_t)(b < 0 ? -b : b));
    return (a < 0) != (b < 0) ? -(int64_t)m : (int64_t)m;
}

// acc += a * b (or -= when negate), in 128-bit two's complement; |a|, |b| < 2^63
static void add_product(uint32_t *acc, int64_t a, int64_t b, bool negate) {
    uint64_t ua = (uint64_t)a, ub = (uint64_t)b;
    if (a < 0) {
        ua = -ua;
        negate = !negate;
    }
    if (b < 0) {
        ub = -ub;
        negate = !negate;
    }
    uint32_t a0 = (uint32_t)ua, a1 = (uint32_t)(ua >> 32), b0 = (uint32_t)ub, b1 = (uint32_t)(ub >> 32);
    // the 128-bit magnitude, column by column: p0 + 2^32 mid + 2^64 hi
    uint64_t t = mul32(a0, b0);
    uint32_t p[4];
    p[0] = (uint32_t)t;
    uint64_t mid = t >> 32;
    t = mul32(a0, b1);
    mid += (uint32_t)t;
    uint64_t hi = t >> 32;
    t = mul32(a1, b0);
    mid += (uint32_t)t;
    hi += t >> 32;
    p[1] = (uint32_t)mid;
    hi += (mid >> 32) + mul32(a1, b1);   // the product is < 2^126: hi cannot wrap
    p[2] = (uint32_t)hi;
    p[3] = (uint32_t)(hi >> 32);
    // subtracting is adding the complement plus one: ~p + 1 = -p
    uint32_t flip = negate ? 0xffffffff : 0;
    uint64_t carry = negate ? 1 : 0;
    for (int i = 0; i < 4; i++) {
        carry += (uint64_t)acc[i] + (p[i] ^ flip);
        acc[i] = (uint32_t)carry;
        carry >>= 32;
    }
}

// a small int with |v| < LIMIT into *v; false for anything else
static bool small_code(mp_obj_t o, int64_t *v) {
    if (!mp_obj_is_small_int(o)) {
        return false;
    }
    mp_int_t n = MP_OBJ_SMALL_INT_VALUE(o);
    if (n <= -LIMIT || n >= LIMIT) {
        return false;
    }
    *v = n;
    return true;
}

// add(acc, x, y, z, out): the sample's 34 monomials added to (out: subtracted from) acc
static mp_obj_t add(size_t n_args, const mp_obj_t *args) {
    mp_buffer_info_t bufinfo;
    mp_get_buffer_raise(args[0], &bufinfo, MP_BUFFER_RW);
    if (bufinfo.len < WORDS * sizeof(uint32_t)) {
        mp_raise_ValueError(MP_ERROR_TEXT("fitsums: acc holds fewer than WORDS words"));
    }
    int64_t f[10];
    f[0] = 1;
    if (!small_code(args[1], &f[1]) || !small_code(args[2], &f[2]) || !small_code(args[3], &f[3])) {
        return mp_const_false;
    }
    f[4] = smul32(f[1], f[1]);
    f[5] = smul32(f[1], f[2]);
    f[6] = smul32(f[1], f[3]);
    f[7] = smul32(f[2], f[2]);
    f[8] = smul32(f[2], f[3]);
    f[9] = smul32(f[3], f[3]);
    bool negate = mp_obj_is_true(args[4]);
    uint32_t *acc = (uint32_t *)bufinfo.buf;
    for (int n = 0; n < SUMS; n++) {
        add_product(acc + 4 * n, f[FACTORS[n][0]], f[FACTORS[n][1]], negate);
    }
    return mp_const_true;
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(add_obj, 5, 5, add);

mp_obj_t mpy_init(mp_obj_fun_bc_t *self, size_t n_args, size_t n_kw, mp_obj_t *args) {
    MP_DYNRUNTIME_INIT_ENTRY
    mp_store_global(MP_QSTR_add, MP_OBJ_FROM_PTR(&add_obj));
    mp_store_global(MP_QSTR_WORDS, MP_OBJ_NEW_SMALL_INT(WORDS));
    MP_DYNRUNTIME_INIT_EXIT
}
