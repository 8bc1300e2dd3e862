#include "py/objtuple.h"

// line.h: the survey's event lines written into a buffer the caller owns (fitsums.line; included
// by fitsums.c), from the bytes formats Python fills with `%` (device/protocol.py RAW_LINE, DATA_LINE):
//
//     n = fitsums.line(buf, fmt, values)   # bytes written into the bytearray buf, or None
//
// fmt's conversions, each taking the next of the tuple `values`:
//     %d            an int                                  -12
//     %s            bytes, as they are                      true
//     %s%d.%0Nd     one int of 1/10^N units (N 1-9)         -0.05 from -5, N 2
//     %d.%0Nd       the same, not negative                  48123.456 from 48123456, N 3
// where Python's `%` takes three values (the sign bytes, the whole part, the fraction: what
// protocol.parts3 makes) or two: the same bytes. None (Python does the line) for anything else:
// a value not a small int of magnitude under 2^32 (every small int on a 32-bit port) or not
// bytes where fmt says, a conversion other than these, values left over or missing, a line
// longer than buf. Nothing is allocated: in Python a block's line was ~14 allocations (tuples of
// parts, the line), each a first-fit search of the heap on a port without a Python stack
// (device/app.py, Frames).

// the decimal digits of v, least significant first, into d (at least `places` + 1 of them:
// zeros in front); how many. Division by 10 as a multiply (a Cortex-M0+ has no divide, and a
// native module links no libgcc): floor(v * 0xCCCCCCCD / 2^35) is v / 10 for every 32-bit v
static int digits(uint32_t v, int places, char *d) {
    int n = 0;
    do {
        uint32_t q = (uint32_t)(mul32(v, 0xCCCCCCCDu) >> 32) >> 3;
        d[n++] = (char)('0' + (v - 10 * q));
        v = q;
    } while (v != 0 || n <= places);
    return n;
}

// one number: sign, digits, the point before the last `places` (0: an integer); false if it is
// not a small int under 2^32 in magnitude, is negative where `negative` forbids, or does not fit
static bool put_number(mp_obj_t o, int places, bool negative, byte **at, byte *end) {
    int64_t v;
    if (!small_within(o, ((int64_t)1) << 32, &v) || (v < 0 && !negative)) {
        return false;
    }
    char d[12];
    int n = digits((uint32_t)(v < 0 ? -v : v), places, d);
    byte *p = *at;
    if (end - p < n + 2) {
        return false;
    }
    if (v < 0) {
        *p++ = '-';
    }
    while (n > 0) {
        *p++ = (byte)d[--n];
        if (n == places && places > 0) {
            *p++ = '.';
        }
    }
    *at = p;
    return true;
}

// whether fmt at t (after a '%') starts with the pattern, '9' standing for a digit 1-9
static bool starts(const byte *t, const byte *end, const char *pattern) {
    for (; *pattern; pattern++, t++) {
        if (t == end || (*pattern == '9' ? *t < '1' || *t > '9' : *t != (byte)*pattern)) {
            return false;
        }
    }
    return true;
}

static mp_obj_t line(size_t n_args, const mp_obj_t *args) {
    mp_buffer_info_t out, fmt;
    mp_get_buffer_raise(args[0], &out, MP_BUFFER_WRITE);
    const mp_obj_type_t *bytes_type = &mp_type_bytes;
    if (mp_obj_get_type(args[1]) != bytes_type || mp_obj_get_type(args[2]) != &mp_type_tuple) {
        return mp_const_none;
    }
    mp_get_buffer_raise(args[1], &fmt, MP_BUFFER_READ);
    mp_obj_tuple_t *tuple = MP_OBJ_TO_PTR(args[2]);
    size_t n_values = tuple->len, used = 0;
    const mp_obj_t *values = tuple->items;
    const byte *t = fmt.buf, *t_end = t + fmt.len;
    byte *p = out.buf, *end = p + out.len;
    while (t < t_end) {
        byte c = *t++;
        if (c != '%') {
            if (p == end) {
                return mp_const_none;
            }
            *p++ = c;
            continue;
        }
        if (used == n_values) {
            return mp_const_none;
        }
        mp_obj_t v = values[used++];
        bool ok;
        if (starts(t, t_end, "s%d.%09d")) {            // signed fixed point: sign, whole, fraction
            ok = put_number(v, t[6] - '0', true, &p, end);
            t += 8;
        } else if (starts(t, t_end, "d.%09d")) {       // the same, not negative
            ok = put_number(v, t[4] - '0', false, &p, end);
            t += 6;
        } else if (starts(t, t_end, "d")) {
            ok = put_number(v, 0, true, &p, end);
            t += 1;
        } else if (starts(t, t_end, "s") && mp_obj_get_type(v) == bytes_type) {
            mp_buffer_info_t b;
            mp_get_buffer_raise(v, &b, MP_BUFFER_READ);
            ok = (size_t)(end - p) >= b.len;
            const byte *s = b.buf;
            for (size_t i = 0; ok && i < b.len; i++) {
                *p++ = s[i];
            }
            t += 1;
        } else {
            ok = false;
        }
        if (!ok) {
            return mp_const_none;
        }
    }
    if (used != n_values) {
        return mp_const_none;
    }
    return mp_obj_new_int((mp_int_t)(p - (byte *)out.buf));
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(line_obj, 3, 3, line);
