// gatesc: the calibration gates' per-sample work (device/gates.py Gates.sample) in C (a
// MicroPython native module, .mpy).
//
//     import gatesc
//     g.sample = gatesc.Sample(g, Gates.sample)    # in Gates.__init__: g.sample(sx, sy, sz) -> bool
//
// Gates.sample is the reference, step for step, on the same state: g._st (an array("i"), its
// slots named in gates.py), g._ring, g._cuts, the coverage's counts and g.hist. This does the
// rate gate (the chord over the last `stride` samples against the allowed turn), the coverage
// cell and its cap, the disturbance gate where a provisional calibration's exact |h_c| is in
// words (_st[PROV] 2: hc.h's, as fitsums.magnitude, against the bounds in g._bounds) with its
// hold, and, taken, fit.add, the cell's count, batches.added() (its count in batches._due here,
// the Python for the sample that closes a batch) and the hist ring. Anything
// else goes to Gates.sample(g, sx, sy, sz) before a thing is written, so the result is the
// reference's: the float |h_c| (_st[PROV] 1), a disturbance's third outlier (the back-off), an
// |h_c| past the words, the tau sums attached (lagfit.py), a sum that is not a small int
// within +-2^31, a shifted sum or a ring entry past +-2^15, the allowed turn _g past 2^16.
// Words: |x|, |r| < 2^15 make |dx| < 2^16, each square < 2^32 (their sum in 64 bits, adds
// only), |x|^2 sums < 3 2^30 < 2^32, (that >> 16) * _g < 2^32; the cell's p << 12 and
// cut * major (|cut| < 2^13, checked at construction) stay under 2^28. No 64-bit multiply,
// divide or variable shift (not linked into a native module on armv6m).

#include "py/dynruntime.h"
#include "wide.h"               // mul32, accumulate, small_within (hc.h's)
#define HC_ONLY
#include "hc.h"                 // hc(): the exact |h_c| of shared.fixedpoint.ExactCorrection

// g._st's slots (gates.py _SEEN ..): the counters and the chain's state, then the constants
enum { SEEN, REJ_RATE, REJ_CAP, REJ_DIST, FRESH, FILLED, RI, RUN, HOLD, HIST_N, HIST_I,
       SH, CX, CY, CZ, STRIDE, G, CAP, EDGE, BACK, PROV, STATE };
#define SUM_LIMIT ((int64_t)1 << 31)
#define V_LIMIT (1 << 15)
#define HIST_WIDTH (5)          // x, y, z, sample index, cell
#define RUN_LENGTH (3)          // gates.py _RUN: outliers in a row that make a disturbance

typedef struct {
    mp_obj_base_t base;
    mp_obj_t gates;
    mp_obj_t python_sample;     // Gates.sample, a function of (gates, sx, sy, sz)
    mp_obj_t fit;
    mp_obj_t batches;
    int32_t *st;
    int32_t *ring;
    const int32_t *cuts;
    uint16_t *counts;
    int32_t *hist;
    int32_t *due;               // batches._due: [open, left] (residuals.py)
    int32_t ncuts;
    int32_t ncells;
    int32_t nring;              // entries (x, y, z) the ring holds
    int32_t nhist;              // entries the hist holds
    int32_t cov_cap;            // Coverage.cap (add_to's), 65535 for None
    mp_obj_t arrays[6];         // held, so their buffers stay alive
} sample_t;

mp_obj_full_type_t sample_type;

// obj's buffer of 4-byte typecode `code` (or 2-byte "H"): its items and how many
static void *buffer(mp_obj_t obj, int code, int32_t *n, mp_obj_t *held) {
    mp_buffer_info_t bufinfo;
    mp_get_buffer_raise(obj, &bufinfo, MP_BUFFER_RW);
    if (bufinfo.typecode != code) {
        mp_raise_TypeError(MP_ERROR_TEXT("gatesc: an array of the wrong type"));
    }
    *n = bufinfo.len >> (code == 'H' ? 1 : 2);
    *held = obj;
    return bufinfo.buf;
}

// n / width, by subtraction (no division is linked into a native module on armv6m)
static int32_t entries(int32_t n, int32_t width) {
    int32_t k = 0;
    for (; n >= width; n -= width) {
        k++;
    }
    return k;
}

// Sample(gates, python_sample)
static mp_obj_t sample_make_new(const mp_obj_type_t *type, size_t n_args, size_t n_kw, const mp_obj_t *args) {
    mp_arg_check_num(n_args, n_kw, 2, 2, false);
    sample_t *self = mp_obj_malloc(sample_t, type);
    mp_obj_t g = args[0];
    mp_obj_t cov = mp_load_attr(g, MP_QSTR_cov);
    int32_t n_st;
    self->gates = g;
    self->python_sample = args[1];
    self->fit = mp_load_attr(g, MP_QSTR_fit);
    self->batches = mp_load_attr(g, MP_QSTR_batches);
    self->st = buffer(mp_load_attr(g, MP_QSTR__st), 'i', &n_st, &self->arrays[0]);
    self->ring = buffer(mp_load_attr(g, MP_QSTR__ring), 'i', &self->nring, &self->arrays[1]);
    self->cuts = buffer(mp_load_attr(g, MP_QSTR__cuts), 'i', &self->ncuts, &self->arrays[2]);
    self->counts = buffer(mp_load_attr(cov, MP_QSTR_counts), 'H', &self->ncells, &self->arrays[3]);
    self->hist = buffer(mp_load_attr(g, MP_QSTR_hist), 'i', &self->nhist, &self->arrays[4]);
    int32_t n_due;
    self->due = buffer(mp_load_attr(self->batches, MP_QSTR__due), 'i', &n_due, &self->arrays[5]);
    self->nring = entries(self->nring, 3);
    self->nhist = entries(self->nhist, HIST_WIDTH);
    mp_obj_t cap = mp_load_attr(cov, MP_QSTR_cap);
    self->cov_cap = cap == mp_const_none ? 65535 : mp_obj_get_int(cap);
    int32_t e = n_st >= STATE ? self->st[EDGE] : 0;
    bool ok = n_st >= STATE && self->ncuts == e - 1 && self->ncells >= 6 * e * e && self->nhist > 0 && n_due >= 2;
    for (int k = 0; ok && k < self->ncuts; k++) {
        ok = self->cuts[k] < (1 << 13) && self->cuts[k] > -(1 << 13);
    }
    if (!ok) {
        mp_raise_ValueError(MP_ERROR_TEXT("gatesc: the gates' arrays do not match"));
    }
    return MP_OBJ_FROM_PTR(self);
}

static inline uint32_t sq(int32_t v) {
    uint32_t a = (uint32_t)(v < 0 ? -v : v);
    return a * a;
}

// the limbs of obj (an array("H")), at least n of them
static const uint16_t *limbs_of(mp_obj_t obj, size_t n) {
    mp_buffer_info_t bufinfo;
    mp_get_buffer_raise(obj, &bufinfo, MP_BUFFER_READ);
    if (bufinfo.typecode != 'H' || bufinfo.len < 2 * n) {
        mp_raise_TypeError(MP_ERROR_TEXT("gatesc: limbs are an array(\"H\")"));
    }
    return (const uint16_t *)bufinfo.buf;
}

// what a sample comes to (decided before anything is written)
enum { NOT_FILLED, TOO_FAST, FULL, OUTLIER, HELD, TAKEN };

// Gates.sample(gates, sx, sy, sz): the whole sample in Python
static mp_obj_t python(sample_t *self, const mp_obj_t *args) {
    mp_obj_t call[4] = {self->gates, args[0], args[1], args[2]};
    return mp_call_function_n_kw(self->python_sample, 4, 0, call);
}

// sample(sx, sy, sz): True if it went into the fit (Gates.sample's verdict)
static mp_obj_t sample_call(mp_obj_t self_in, size_t n_args, size_t n_kw, const mp_obj_t *args) {
    if (n_args != 3 || n_kw) {
        mp_raise_TypeError(MP_ERROR_TEXT("gatesc: sample takes sx, sy, sz"));
    }
    sample_t *self = MP_OBJ_TO_PTR(self_in);
    int32_t *st = self->st;
    int32_t stride = st[STRIDE], ri = st[RI], sh = st[SH];
    int32_t s[3], v[3];
    bool ok = st[PROV] != 1 && stride > 0 && stride <= self->nring && ri >= 0 && ri < stride && sh >= 0 && sh < 32
        && st[G] > 0 && st[G] < (1 << 16);
    for (int j = 0; ok && j < 3; j++) {
        ok = mp_obj_is_small_int(args[j]);
        if (ok) {
            mp_int_t a = MP_OBJ_SMALL_INT_VALUE(args[j]);
            ok = a < SUM_LIMIT && a > -SUM_LIMIT;
            s[j] = (int32_t)a;
            // x = (sx >> sh) - cx: >> of a negative int32 is arithmetic in gcc (Python's floor)
            int64_t x = (int64_t)(s[j] >> sh) - st[CX + j];
            ok = ok && x < V_LIMIT && x > -V_LIMIT;
            v[j] = (int32_t)x;
        }
    }
    ok = ok && mp_load_attr(self->gates, MP_QSTR_tau_sums) == mp_const_none;
    int32_t filled = st[FRESH] ? 0 : st[FILLED];
    int32_t *r = self->ring + 3 * ri;
    for (int j = 0; ok && filled >= stride && j < 3; j++) {
        ok = r[j] < V_LIMIT && r[j] > -V_LIMIT;
    }
    if (!ok) {
        return python(self, args);
    }
    int verdict = TAKEN;
    int32_t cell = 0;
    bool settled = true;
    if (filled < stride) {
        verdict = NOT_FILLED;
    } else {
        // 1. rotation rate: chord^2 > angle^2 |r|^2, (|r|^2 >> 16) * _g
        uint64_t d2 = (uint64_t)sq(v[0] - r[0]) + sq(v[1] - r[1]) + sq(v[2] - r[2]);
        uint32_t r2 = sq(v[0]) + sq(v[1]) + sq(v[2]);
        if (d2 > (uint64_t)((r2 >> 16) * (uint32_t)st[G]) || r2 == 0) {
            verdict = TOO_FAST;     // too fast, or no direction (a dead front end)
        }
    }
    if (verdict == TAKEN) {
        // 2. coverage cell (shared.coverage.Coverage.cell) and its cap
        int32_t a[3], face, major, p, q;
        for (int j = 0; j < 3; j++) {
            a[j] = v[j] < 0 ? -v[j] : v[j];
        }
        if (a[0] >= a[1] && a[0] >= a[2]) {
            face = v[0] >= 0 ? 0 : 1;
            major = a[0];
            p = v[1];
            q = v[2];
        } else if (a[1] >= a[2]) {
            face = v[1] >= 0 ? 2 : 3;
            major = a[1];
            p = v[0];
            q = v[2];
        } else {
            face = v[2] >= 0 ? 4 : 5;
            major = a[2];
            p = v[0];
            q = v[1];
        }
        p *= 1 << 12;               // TAN_BITS
        q *= 1 << 12;
        int32_t i = 0, k = 0, e = st[EDGE];
        for (int c = 0; c < self->ncuts; c++) {
            int32_t cut = self->cuts[c] * major;
            i += p >= cut;
            k += q >= cut;
        }
        cell = (face * e + i) * e + k;
        int32_t n = self->counts[cell];
        if (n >= st[CAP]) {
            verdict = FULL;
        } else if (st[PROV] && (n >= 3 || st[HOLD])) {
            // 3. disturbance: the exact |h_c| (hc.h, as fitsums.magnitude) against the bounds
            mp_obj_t ex = mp_load_attr(self->gates, MP_QSTR__exact);
            if (ex == mp_const_none) {
                return python(self, args);      // made to take the float |h_c| (a test)
            }
            const uint16_t *num = limbs_of(mp_load_attr(ex, MP_QSTR__native), 4 * NUMBERS);
            const uint16_t *b = limbs_of(mp_load_attr(self->gates, MP_QSTR__bounds), 16);
            int64_t s64[3] = {s[0], s[1], s[2]};
            uint64_t f;
            if (!hc(num, s64, &f)) {
                return python(self, args);      // past the words: ExactCorrection's Python
            }
            int64_t m = (int64_t)f;             // < 2^63
            if (m > number(b) || m < number(b + 4)) {
                if (st[RUN] + 1 == RUN_LENGTH) {
                    return python(self, args);  // a disturbance: Gates._backoff
                }
                verdict = OUTLIER;
            } else if (st[HOLD]) {
                verdict = HELD;
                settled = !(m > number(b + 8) || m < number(b + 12));
            }
            if (verdict != OUTLIER) {
                st[RUN] = 0;
            }
        }
    }
    // the chain: seen, the ring of the last `stride` samples
    int32_t seen = ++st[SEEN];
    st[FRESH] = 0;
    r[0] = v[0];
    r[1] = v[1];
    r[2] = v[2];
    st[RI] = ri + 1 == stride ? 0 : ri + 1;
    st[FILLED] = filled < stride ? filled + 1 : filled;
    // (ifs, not a switch: its Thumb-1 jump table needs a libgcc helper a native module lacks)
    if (verdict == TOO_FAST) {
        st[REJ_RATE] += 1;
    } else if (verdict == FULL) {
        st[REJ_CAP] += 1;
    } else if (verdict == OUTLIER) {
        st[REJ_DIST] += 1;
        st[RUN] += 1;
    } else if (verdict == HELD) {
        // back-off: hold until |h_c| is within a tenth of the gate for `back` samples
        st[REJ_DIST] += 1;
        st[HOLD] = settled ? st[HOLD] - 1 : st[BACK];
    }
    if (verdict != TAKEN) {
        return mp_const_false;
    }
    // taken: fit.add, the cell's count (Coverage.add_to), the batches, the hist ring
    mp_obj_t call[5];
    mp_load_method(self->fit, MP_QSTR_add, call);
    call[2] = args[0];
    call[3] = args[1];
    call[4] = args[2];
    mp_fun_table.call_method_n_kw(3, 0, call);      // (dynruntime.h names no mp_call_method_n_kw)
    int32_t n = self->counts[cell];
    if (n < self->cov_cap && n < 65535) {
        self->counts[cell] = n + 1;
    }
    // ResidualBatches.added: counted here while the batch stays open (no Python frame a
    // sample, ~3.5 k cycles on an RP2040); the sample that fills it, its Python (the close)
    int32_t *due = self->due;
    if (due[1] > 1 && due[0] >= 0) {
        due[0] += 1;
        due[1] -= 1;
    } else {
        mp_load_method(self->batches, MP_QSTR_added, call);
        mp_fun_table.call_method_n_kw(0, 0, call);
    }
    int32_t hi = st[HIST_I];
    if (hi < 0 || hi >= self->nhist) {
        mp_raise_ValueError(MP_ERROR_TEXT("gatesc: hist_i out of the ring"));
    }
    int32_t *h = self->hist + HIST_WIDTH * hi;
    h[0] = s[0];
    h[1] = s[1];
    h[2] = s[2];
    h[3] = seen;
    h[4] = cell;
    st[HIST_I] = hi + 1 == self->nhist ? 0 : hi + 1;
    if (st[HIST_N] < self->nhist) {
        st[HIST_N] += 1;
    }
    return mp_const_true;
}

mp_obj_t mpy_init(mp_obj_fun_bc_t *self, size_t n_args, size_t n_kw, mp_obj_t *args) {
    MP_DYNRUNTIME_INIT_ENTRY
    sample_type.base.type = (void *)&mp_type_type;
    sample_type.flags = MP_TYPE_FLAG_NONE;
    sample_type.name = MP_QSTR_Sample;
    MP_OBJ_TYPE_SET_SLOT(&sample_type, make_new, sample_make_new, 0);
    MP_OBJ_TYPE_SET_SLOT(&sample_type, call, sample_call, 1);
    mp_store_global(MP_QSTR_Sample, MP_OBJ_FROM_PTR(&sample_type));
    mp_store_global(MP_QSTR_STATE, MP_OBJ_NEW_SMALL_INT(STATE));
    MP_DYNRUNTIME_INIT_EXIT
}
