// wide.h: what fitsums.c, hc.h and gatesc.c share: a 32 x 32 -> 64-bit product where the
// Cortex-M0+ and libgcc lack one, a four-word signed accumulate, the small-int check. Included
// once per module (each .mpy links its own copy).

#include "py/dynruntime.h"

// a * b in 64 bits: the Cortex-M0+ multiplies 32 x 32 -> 32 only, and libgcc's
// 64-bit multiply is not linked into a native module, so 16-bit products there
static inline uint64_t mul32(uint32_t a, uint32_t b) {
    #if defined(__ARM_ARCH_6M__)
    uint32_t al = a & 0xffff, ah = a >> 16, bl = b & 0xffff, bh = b >> 16;
    uint64_t mid = (uint64_t)(al * bh) + (ah * bl);
    return ((uint64_t)(ah * bh) << 32) + (mid << 16) + al * bl;
    #else
    return (uint64_t)a * b;
    #endif
}

// acc += m (or -= when negate), m = m0 + 2^32 m1 + 2^64 m2 a magnitude; subtracting is
// adding the complement plus one (~m + 1 = -m), carried through the four words
static inline void accumulate(uint32_t *acc, uint32_t m0, uint32_t m1, uint32_t m2, bool negate) {
    uint32_t flip = negate ? 0xffffffff : 0;
    #if defined(__ARM_ARCH_6M__)
    // Thumb-1 has add-with-carry, which C cannot ask for: one ADCS chain for the (complemented)
    // magnitude, a second for the complement's +1
    uint32_t a0 = acc[0], a1 = acc[1], a2 = acc[2], a3 = acc[3];
    uint32_t w0 = m0 ^ flip, w1 = m1 ^ flip, w2 = m2 ^ flip;
    __asm__ (".syntax unified\n\t"      // gcc's Thumb-1 default is the older, divided syntax
             "adds %[a0], %[a0], %[w0]\n\t"
             "adcs %[a1], %[w1]\n\t"
             "adcs %[a2], %[w2]\n\t"
             "adcs %[a3], %[flip]\n\t"
             "movs %[w0], #1\n\t"
             "ands %[w0], %[flip]\n\t"
             "movs %[w1], #0\n\t"
             "adds %[a0], %[a0], %[w0]\n\t"
             "adcs %[a1], %[w1]\n\t"
             "adcs %[a2], %[w1]\n\t"
             "adcs %[a3], %[w1]\n\t"
             ".syntax divided"
             : [a0] "+l"(a0), [a1] "+l"(a1), [a2] "+l"(a2), [a3] "+l"(a3), [w0] "+l"(w0), [w1] "+l"(w1)
             : [w2] "l"(w2), [flip] "l"(flip)
             : "cc");
    acc[0] = a0;
    acc[1] = a1;
    acc[2] = a2;
    acc[3] = a3;
    #else
    uint64_t c = (uint64_t)acc[0] + (m0 ^ flip) + (negate ? 1 : 0);
    acc[0] = (uint32_t)c;
    c = (c >> 32) + acc[1] + (m1 ^ flip);
    acc[1] = (uint32_t)c;
    c = (c >> 32) + acc[2] + (m2 ^ flip);
    acc[2] = (uint32_t)c;
    acc[3] += (uint32_t)(c >> 32) + flip;
    #endif
}

// a small int with |v| < limit, in *v; false for anything else (a code, a magnitude's sum)
static inline bool small_within(mp_obj_t o, int64_t limit, int64_t *v) {
    if (!mp_obj_is_small_int(o)) {
        return false;
    }
    int64_t n = MP_OBJ_SMALL_INT_VALUE(o);
    if (n <= -limit || n >= limit) {
        return false;
    }
    *v = n;
    return true;
}

