// exact_objects.h, for linalgc.c after exact_body.h: its kernels as linalgc's functions, the power sums
// as Python ints in and out where the solver keeps them, and as words in a bytearray between them.

// ****** the Python side: ints in and out as the solver keeps them, the sums' words in a bytearray ******
// (set by linalgc.c's mpy_init, where mpy_ld finds their qstrs; not static: mpy_ld places no static
// variable in bss. The limits are heap ints, kept for the collector in the module's _EXACT.)
mp_obj_t e_limits[2];           // -2**EBITS, 2**EBITS
mp_obj_t e_little, e_bytearray, e_from_bytes, e_to_bytes;

// an int with |o| < 2**EBITS into EW words; false for anything else (a bool, a float, a bigger int)
static bool e_read(mp_obj_t o, uint32_t *x) {
    if (mp_obj_is_small_int(o)) {
        int64_t v = MP_OBJ_SMALL_INT_VALUE(o);
        for (size_t i = 0; i < EW; i++) {
            x[i] = i == 0 ? (uint32_t)v : i == 1 ? (uint32_t)((uint64_t)v >> 32) : v < 0 ? 0xffffffff : 0;
        }
        return true;
    }
    if (mp_obj_get_type(o) != int_type || at_least(o, e_limits[1]) || at_least(e_limits[0], o)) {
        return false;
    }
    // the magnitude's bytes (int.to_bytes of a negative int: two's complement on 1.28, an error on 1.29)
    bool negative = at_least(MP_OBJ_NEW_SMALL_INT(-1), o);
    mp_obj_t call[3] = {negative ? mp_unary_op(MP_UNARY_OP_NEGATIVE, o) : o, MP_OBJ_NEW_SMALL_INT(4 * EW), e_little};
    mp_buffer_info_t buf;
    mp_get_buffer_raise(mp_call_function_n_kw(e_to_bytes, 3, 0, call), &buf, MP_BUFFER_READ);
    const uint8_t *b = buf.buf;
    for (size_t i = 0; i < EW; i++) {
        x[i] = b[4 * i] | (uint32_t)b[4 * i + 1] << 8 | (uint32_t)b[4 * i + 2] << 16 | (uint32_t)b[4 * i + 3] << 24;
    }
    e_negated(x, x, negative);
    return true;
}

// the int of EW words: a small one as it is, a bigger one by int.from_bytes of its magnitude
static mp_obj_t e_obj(const uint32_t *x) {
    uint32_t m[EW];
    e_abs(m, x);
    size_t top = EW - 1;
    while (top && !m[top]) {
        top--;
    }
    bool negative = e_negative(x);
    if (!top && m[0] < 0x80000000u) {
        return mp_obj_new_int(negative ? -(mp_int_t)m[0] : (mp_int_t)m[0]);
    }
    uint8_t b[4 * EW];
    for (size_t i = 0; i <= top; i++) {
        b[4 * i] = m[i];
        b[4 * i + 1] = m[i] >> 8;
        b[4 * i + 2] = m[i] >> 16;
        b[4 * i + 3] = m[i] >> 24;
    }
    mp_obj_t call[3] = {MP_OBJ_FROM_PTR(int_type), mp_obj_new_bytes(b, 4 * (top + 1)), e_little};
    mp_obj_t v = mp_call_function_n_kw(e_from_bytes, 3, 0, call);
    return negative ? mp_unary_op(MP_UNARY_OP_NEGATIVE, v) : v;
}

// a new bytearray for ECOUNT numbers (the heap's blocks are aligned for words) and its words
static mp_obj_t e_new(uint32_t **w) {
    mp_obj_t n = MP_OBJ_NEW_SMALL_INT(4 * EW * ECOUNT), out = mp_call_function_n_kw(e_bytearray, 1, 0, &n);
    mp_buffer_info_t buf;
    mp_get_buffer_raise(out, &buf, MP_BUFFER_WRITE);
    *w = buf.buf;
    return out;
}

// the words of a sums' bytearray, or NULL
static uint32_t *e_sums(mp_obj_t o) {
    mp_buffer_info_t buf;
    if (!mp_get_buffer(o, &buf, MP_BUFFER_READ) || buf.len != 4 * EW * ECOUNT || ((uintptr_t)buf.buf & 3)) {
        return NULL;
    }
    return buf.buf;
}

// exact_words(sums): the ECOUNT ints as words (a bytearray), or None
static mp_obj_t exact_words(mp_obj_t sums) {
    size_t n;
    mp_obj_t *items;
    if (mp_obj_get_type(sums) != &mp_type_list) {
        return mp_const_none;
    }
    mp_obj_get_array_dyn(sums, &n, &items);
    uint32_t *w;
    mp_obj_t out = e_new(&w);
    for (size_t i = 0; i < ECOUNT; i++) {
        if (i >= n || !e_read(items[i], w + EW * i)) {
            return mp_const_none;
        }
    }
    return out;
}
static MP_DEFINE_CONST_FUN_OBJ_1(exact_words_obj, exact_words);

// recentre(words, c, chains): moments.recentred of the sums in words on c (3 ints), chains
// moments._CHAINS: a list of ECOUNT Nones (their ints: exact_ints) and, after them, the words; or None
static mp_obj_t recentre(mp_obj_t src, mp_obj_t c, mp_obj_t chains) {
    mp_obj_t *ci, *chi;
    const uint32_t *in = e_sums(src);
    if (!in || items_of(c, &ci) != 3 || items_of(chains, &chi) != 3) {
        return mp_const_none;
    }
    uint32_t cw[3 * EW];
    const uint8_t *ch[3];
    size_t ends[3];
    for (size_t a = 0; a < 3; a++) {
        mp_buffer_info_t buf;
        if (!e_read(ci[a], cw + EW * a) || !mp_get_buffer(chi[a], &buf, MP_BUFFER_READ)) {
            return mp_const_none;
        }
        ch[a] = buf.buf;
        ends[a] = buf.len;
        for (size_t p = 0; p < buf.len; p += ch[a][p] + 1) {      // well formed: every chain one long
            if (!ch[a][p]) {                                        // at least, every index a sum's
                return mp_const_none;
            }
            for (size_t j = 1; j <= ch[a][p]; j++) {
                if (p + j >= buf.len || ch[a][p + j] >= ECOUNT) {
                    return mp_const_none;
                }
            }
        }
    }
    uint32_t *s;
    mp_obj_t words = e_new(&s);
    for (size_t i = 0; i < EW * ECOUNT; i++) {
        s[i] = in[i];
    }
    if (!e_recentre(s, cw, ch, ends)) {
        return mp_const_none;
    }
    mp_obj_t items[ECOUNT + 1];
    for (size_t i = 0; i < ECOUNT; i++) {
        items[i] = mp_const_none;       // as ints only where asked for (exact_ints): ~6 k cycles each on a Pico
    }
    items[ECOUNT] = words;
    return mp_obj_new_list(ECOUNT + 1, items);
}
static MP_DEFINE_CONST_FUN_OBJ_3(recentre_obj, recentre);

// exact(words, a_int, tables, f3): Problem.exact's (g_A, T, RSS) from the sums in words; or None
static mp_obj_t exact(size_t n_args, const mp_obj_t *args) {
    mp_obj_t *ai;
    mp_buffer_info_t idx;
    const uint32_t *s = e_sums(args[0]);
    if (!s || items_of(args[1], &ai) != 6 || !mp_get_buffer(args[2], &idx, MP_BUFFER_READ) || idx.len != 63
        || !mp_obj_is_small_int(args[3]) || MP_OBJ_SMALL_INT_VALUE(args[3]) < 0 || MP_OBJ_SMALL_INT_VALUE(args[3]) > 200) {
        return mp_const_none;
    }
    const uint8_t *ix = idx.buf;
    uint32_t a[6 * EW], out[10 * EW];
    for (size_t i = 0; i < 63; i++) {
        if (ix[i] >= ECOUNT) {
            return mp_const_none;
        }
    }
    for (size_t k = 0; k < 6; k++) {
        if (!e_read(ai[k], a + EW * k)) {
            return mp_const_none;
        }
    }
    if (!e_exact(out, s, a, ix, MP_OBJ_SMALL_INT_VALUE(args[3]))) {
        return mp_const_none;
    }
    mp_obj_t ga[6], t[3];
    for (size_t r = 0; r < 9; r++) {
        *(r < 6 ? ga + r : t + r - 6) = e_obj(out + EW * r);
    }
    mp_obj_t res[3] = {mp_obj_new_list(6, ga), mp_obj_new_list(3, t), e_obj(out + EW * 9)};
    return mp_obj_new_tuple(3, res);
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(exact_obj, 4, 4, exact);

// exact_ints(words[, indices]): the ECOUNT ints of a sums' words (a list; with indices, those alone
// and None elsewhere), or None
static mp_obj_t exact_ints(size_t n_args, const mp_obj_t *args) {
    const uint32_t *s = e_sums(args[0]);
    mp_buffer_info_t idx;
    idx.len = 0;        // (field by field: an initialiser is a memset, which a native module does not link)
    if (!s || (n_args > 1 && !mp_get_buffer(args[1], &idx, MP_BUFFER_READ))) {
        return mp_const_none;
    }
    mp_obj_t items[ECOUNT];
    for (size_t i = 0; i < ECOUNT; i++) {
        items[i] = n_args > 1 ? mp_const_none : e_obj(s + EW * i);
    }
    for (size_t k = 0; k < idx.len; k++) {
        size_t i = ((const uint8_t *)idx.buf)[k];
        if (i >= ECOUNT) {
            return mp_const_none;
        }
        items[i] = e_obj(s + EW * i);
    }
    return mp_obj_new_list(ECOUNT, items);
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(exact_ints_obj, 1, 2, exact_ints);

// frame_floats(words, indices, degrees, frac): quadric.frame_means's list from the sums' words, or None
static mp_obj_t frame_floats(size_t n_args, const mp_obj_t *args) {
    mp_buffer_info_t idx, deg;
    const uint32_t *s = e_sums(args[0]);
    if (!s || !mp_get_buffer(args[1], &idx, MP_BUFFER_READ) || !mp_get_buffer(args[2], &deg, MP_BUFFER_READ)
        || deg.len != ECOUNT || !mp_obj_is_small_int(args[3]) || MP_OBJ_SMALL_INT_VALUE(args[3]) < 0
        || MP_OBJ_SMALL_INT_VALUE(args[3]) > 1000) {
        return mp_const_none;
    }
    for (size_t k = 0; k < idx.len; k++) {
        if (((const uint8_t *)idx.buf)[k] >= ECOUNT) {
            return mp_const_none;
        }
    }
    return IN_USE(frame_floats, s, idx.buf, idx.len, deg.buf, MP_OBJ_SMALL_INT_VALUE(args[3]));
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(frame_floats_obj, 4, 4, frame_floats);

// scaled_words(words, bits, degrees): moments.scaled(sums, 2**bits) of the sums' words, each sum shifted
// by bits times its degree: a list of ECOUNT Nones and the words (as recentre's); None past EBITS
static mp_obj_t scaled_words(mp_obj_t words, mp_obj_t bits_in, mp_obj_t degrees) {
    mp_buffer_info_t deg;
    const uint32_t *in = e_sums(words);
    if (!in || !mp_obj_is_small_int(bits_in) || !mp_get_buffer(degrees, &deg, MP_BUFFER_READ) || deg.len != ECOUNT) {
        return mp_const_none;
    }
    mp_int_t bits = MP_OBJ_SMALL_INT_VALUE(bits_in);
    const uint8_t *d = deg.buf;
    for (size_t i = 0; i < ECOUNT; i++) {
        if (bits < 0 || bits > EBITS || d[i] > 4 || e_bits(in + EW * i) + bits * d[i] >= EBITS) {
            return mp_const_none;
        }
    }
    uint32_t *s;
    mp_obj_t items[ECOUNT + 1];
    items[ECOUNT] = e_new(&s);       // (zeroed)
    for (size_t i = 0; i < ECOUNT; i++) {
        e_add_shifted(s + EW * i, in + EW * i, bits * d[i], false, EW);
        items[i] = mp_const_none;
    }
    return mp_obj_new_list(ECOUNT + 1, items);
}
static MP_DEFINE_CONST_FUN_OBJ_3(scaled_words_obj, scaled_words);
