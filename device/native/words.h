// words.h: what the native pushes (screenc.c, delagc.c) share: 64-bit words from 32-bit ones
// where the Cortex-M0+ and libgcc lack them, small-int checks, and the call that hands a push
// to its Python reference. Included once per module (each .mpy links its own copy).

#include "py/dynruntime.h"
#include "py/smallint.h"

// a * b (mod 2^64; the callers keep it under 2^63). The Cortex-M0+ multiplies 32 x 32 ->
// 32 only, and libgcc's 64-bit multiply is not linked into a native module: 16-bit products
// there (as in fitsums.c)
static inline uint64_t mul(uint64_t a, uint32_t b) {
    uint32_t lo = (uint32_t)a, hi = (uint32_t)(a >> 32);
    #if defined(__ARM_ARCH_6M__)
    uint32_t ll = lo & 0xffff, lh = lo >> 16, bl = b & 0xffff, bh = b >> 16;
    uint64_t low = ((uint64_t)(lh * bh) << 32) + (((uint64_t)(ll * bh) + lh * bl) << 16) + ll * bl;
    #else
    uint64_t low = (uint64_t)lo * b;
    #endif
    return low + ((uint64_t)(hi * b) << 32);
}

// v >> s for 0 <= s < 64, in 32-bit words (libgcc's 64-bit shifts are not linked either)
static inline uint64_t shr(uint64_t v, uint32_t s) {
    uint32_t lo = (uint32_t)v, hi = (uint32_t)(v >> 32);
    if (s >= 32) {
        return hi >> (s - 32);
    }
    if (s == 0) {
        return v;
    }
    return ((uint64_t)(hi >> s) << 32) | (lo >> s) | (hi << (32 - s));
}

static inline bool small(mp_obj_t o, int64_t limit, int64_t *out) {
    if (!mp_obj_is_small_int(o)) {
        return false;
    }
    *out = MP_OBJ_SMALL_INT_VALUE(o);
    return *out < limit && *out > -limit;
}

static inline bool fits(int64_t v) {
    return v >= MP_SMALL_INT_MIN && v <= MP_SMALL_INT_MAX;
}

// reference(obj, x, y, z, t): the whole push in Python
static mp_obj_t call_python(mp_obj_t reference, mp_obj_t obj, const mp_obj_t *args) {
    mp_obj_t call[5];
    call[0] = obj;              // (one by one: a loop becomes a memcpy, which is not linked)
    call[1] = args[0];
    call[2] = args[1];
    call[3] = args[2];
    call[4] = args[3];
    return mp_call_function_n_kw(reference, 5, 0, call);
}
