// drdy: the DRDY handler of device/acquisition.py in C (a MicroPython native module, .mpy),
// so that the hard IRQ of a conversion never enters the bytecode VM.
//
//     import drdy
//     isr = drdy.Handler(acq.state, acq.acc, acq.ring, acq._shape, acq._f0, acq._f1, board.drdy_bus)
//     board.attach_drdy(isr, rate, acq.account_gap)        # isr(pin): one conversion
//
// Acquisition._isr is the reference, word for word: the same counters (FRAMES and the others
// wrap from 2^30 - 1 to 0), the same boxcar phase, the same 24-bit two's-complement sums, bad
// status headers (BADSYNC, _SPOIL, LASTBAD), block completion (BLOCKS, DISCARDED), and the ring
// (five ints a block, HEAD, OVERFLOW), all in the same array('i') objects, so the main loop's
// reader (Acquisition.poll, account_gap, status) does not know which handler ran. shape is an
// array('i') of [decim, decim - window, counted] that Acquisition.set_decimation keeps current;
// counted: the board counts the frames before the window (a PIO state machine on rp2,
// hal_micropython.Board.count_drdy) and the handler runs on the window's frames alone.
// [DS] = ADS1292 datasheet SBAS502C.
//
// The frames are read as the HAL reads them (hal_micropython.Board.spi_readinto): drdy_bus is
// its list [cs0, cs1, readinto], the two chip-select Pins and the SPI's bound readinto, kept
// current by its set_spi_rate. Calling them allocates nothing: a Pin's call sets its level, a
// bound method of two arguments passes them on the C stack (py/objboundmeth.c uses the heap
// only past four), SPI.readinto fills the buffer in place. Nothing here allocates either (the
// buffers' addresses are taken once, in make_new): it runs as a hard IRQ, with the heap locked.
// The ring's other side, in the main loop (the rest of the file):
//     acq.poll = drdy.Drain(acq)                  # n = acq.poll(on_sample, limit, on_gap)
//     out.sample = drdy.Sample(out, fitsums.survey or None)   # out.sample(sx, sy, sz, st)
//
// Drain is Acquisition.poll and Sample device/survey.py's Output.sample, word for word: the same
// state read and written, the same calls in the same order, each as the VM makes it (an instance
// attribute before the class's method, a method called without a bound-method object), so they
// do what the objects they call do (the screen's and de-lag's pushes, native or not; fitsums.survey;
// the Python fall-backs). They spare the VM's frames and bytecodes (~2 k cycles a Python call on
// an RP2040): a survey sample makes no Python frame where the screen, de-lag and survey are in C.

#include "py/dynruntime.h"
#include "py/objlist.h"

// state array indices, as acquisition.py names them
#define HEAD (0)
#define TAIL (1)
#define OVERFLOW (2)
#define FRAMES (3)
#define BADSYNC (4)
#define PHASE (5)
#define SPOIL (6)
#define DISCARDED (7)
#define BLOCKS (8)
#define LASTBAD (10)
#define NSTATE (11)             // the handler's; the reader's (poll's) after them:
#define SAMPLES (11)
#define GAPS (12)
#define LAST (13)
#define NREADER (14)
// shape array indices
#define DECIM (0)
#define FIRST (1)               // decim - window: the first frame of a block that is read
#define COUNTED (2)             // 1: the frames before FIRST were counted by the board

#define WRAP (0x3FFFFFFF)       // counters wrap from 2^30 - 1 to 0 (a small int on every port)
#define SLOTS (5)               // a ring slot: x, y, z, temperature sums, block number
#define FRAME_BYTES (9)         // 24 status bits + 2 x 24-bit channels [DS §8.5.1.5]
#define STATUS_MASK (0xF0)
#define STATUS_SYNC (0xC0)      // frame header nibble 1100 [DS §8.5.1.5]

typedef struct {
    mp_obj_base_t base;
    int32_t *state;
    int32_t *acc;               // the open block's x, y, z, temperature sums
    int32_t *ring;
    int32_t *shape;
    int32_t ring_frames;        // ring slots: len(ring) / SLOTS, as Acquisition.ring_frames
    uint8_t *frame[2];          // chip 0's and chip 1's frame buffers
    mp_obj_t frame_obj[2];      // the same buffers, for readinto
    mp_obj_t bus;               // the HAL's list [cs0, cs1, readinto]
    mp_obj_t arrays[4];         // state, acc, ring, shape: held, so their items stay alive
} handler_t;

mp_obj_full_type_t handler_type;

// the items of an array('i') of at least `ints` ints; their number in *len
static int32_t *ints_of(mp_obj_t o, size_t ints, size_t *len) {
    mp_buffer_info_t info;
    mp_get_buffer_raise(o, &info, MP_BUFFER_RW);
    if (info.typecode != 'i' || info.len < ints * sizeof(int32_t)) {
        mp_raise_ValueError(MP_ERROR_TEXT("drdy: expected an array('i') long enough"));
    }
    if (len != NULL) {
        *len = info.len / sizeof(int32_t);
    }
    return (int32_t *)info.buf;
}

// Handler(state, acc, ring, shape, frame0, frame1, bus)
static mp_obj_t handler_make_new(const mp_obj_type_t *type, size_t n_args, size_t n_kw, const mp_obj_t *args) {
    mp_arg_check_num(n_args, n_kw, 7, 7, false);
    handler_t *self = mp_obj_malloc(handler_t, type);
    size_t ring_ints;
    self->state = ints_of(args[0], NSTATE, NULL);
    self->acc = ints_of(args[1], 4, NULL);
    self->ring = ints_of(args[2], SLOTS, &ring_ints);
    self->shape = ints_of(args[3], 3, NULL);
    // len(ring) / SLOTS, by counting: the Cortex-M0+ has no divide, and libgcc is not linked
    self->ring_frames = 0;
    while ((size_t)(self->ring_frames + 1) * SLOTS <= ring_ints) {
        self->ring_frames++;
    }
    for (int chip = 0; chip < 2; chip++) {
        mp_buffer_info_t info;
        mp_get_buffer_raise(args[4 + chip], &info, MP_BUFFER_RW);
        if (info.len < FRAME_BYTES) {
            mp_raise_ValueError(MP_ERROR_TEXT("drdy: a frame buffer holds 9 bytes"));
        }
        self->frame[chip] = (uint8_t *)info.buf;
        self->frame_obj[chip] = args[4 + chip];
    }
    if (mp_obj_get_type(args[6]) != &mp_type_list || ((mp_obj_list_t *)MP_OBJ_TO_PTR(args[6]))->len != 3) {
        mp_raise_TypeError(MP_ERROR_TEXT("drdy: bus is a list [cs0, cs1, readinto]"));
    }
    self->bus = args[6];
    for (int k = 0; k < 4; k++) {
        self->arrays[k] = args[k];
    }
    return MP_OBJ_FROM_PTR(self);
}

// CS low, clock in the frame with DIN low, CS high: hal_micropython.Board.spi_readinto
static void read_frame(handler_t *self, const mp_obj_t *bus, int chip) {
    mp_obj_t low = MP_OBJ_NEW_SMALL_INT(0), high = MP_OBJ_NEW_SMALL_INT(1);
    mp_obj_t args[2] = {self->frame_obj[chip], low};
    mp_call_function_n_kw(bus[chip], 1, 0, &low);
    mp_call_function_n_kw(bus[2], 2, 0, args);      // DIN held low while reading [DS §8.5.1.5]
    mp_call_function_n_kw(bus[chip], 1, 0, &high);
}

// a counter's next value: + 1, from 2^30 - 1 back to 0
static inline int32_t next_count(int32_t n) {
    return n != WRAP ? n + 1 : 0;
}

// a channel: 24-bit two's complement, MSB first
static inline int32_t code24(const uint8_t *b) {
    int32_t v = ((int32_t)b[0] << 16) | ((int32_t)b[1] << 8) | b[2];
    return v - ((v & 0x800000) << 1);
}

// acc += v, in 32-bit words (the sums stay under 2^29: window <= 64, acquisition.py)
static inline void add_code(int32_t *acc, int32_t v) {
    *acc = (int32_t)((uint32_t)*acc + (uint32_t)v);
}

// handler(pin): one conversion, as Acquisition._isr(pin)
static mp_obj_t handler_call(mp_obj_t self_in, size_t n_args, size_t n_kw, const mp_obj_t *args) {
    (void)args;
    if (n_args > 1 || n_kw) {
        mp_raise_TypeError(MP_ERROR_TEXT("drdy: the handler takes the pin only"));
    }
    handler_t *self = MP_OBJ_TO_PTR(self_in);
    int32_t *st = self->state;
    st[FRAMES] = next_count(st[FRAMES]);
    int32_t p = st[PHASE];
    if (p < self->shape[FIRST] && self->shape[COUNTED]) {
        // the board counted the frames before the window: the first of the window's is here
        int32_t k = self->shape[FIRST] - p, n = st[FRAMES];
        st[FRAMES] = n <= WRAP - k ? n + k : n - WRAP - 1 + k;
        p = self->shape[FIRST];
    }
    int32_t q = p + 1;
    if (q == self->shape[DECIM]) {
        q = 0;
    }
    st[PHASE] = q;
    if (p < self->shape[FIRST]) {
        return mp_const_none;      // outside the boxcar: not read, the next conversion replaces it
    }
    const mp_obj_t *bus = ((mp_obj_list_t *)MP_OBJ_TO_PTR(self->bus))->items;
    read_frame(self, bus, 0);
    read_frame(self, bus, 1);
    const uint8_t *f0 = self->frame[0], *f1 = self->frame[1];
    int32_t *a = self->acc;
    if ((f0[0] & STATUS_MASK) != STATUS_SYNC || (f1[0] & STATUS_MASK) != STATUS_SYNC) {
        st[BADSYNC] = next_count(st[BADSYNC]);
        st[SPOIL] = 1;
        st[LASTBAD] = (f0[0] & STATUS_MASK) != STATUS_SYNC ? f0[0] : 256 | f1[0];
    } else {
        add_code(&a[0], code24(f0 + 3));     // chip 0: X (CH1), Y (CH2)
        add_code(&a[1], code24(f0 + 6));
        add_code(&a[2], code24(f1 + 3));     // chip 1: Z (CH1), die temperature (CH2)
        add_code(&a[3], code24(f1 + 6));
    }
    if (q) {
        return mp_const_none;      // block still open
    }
    int32_t blk = st[BLOCKS];
    st[BLOCKS] = next_count(blk);
    if (st[SPOIL]) {
        st[SPOIL] = 0;
        st[DISCARDED] = next_count(st[DISCARDED]);
    } else {
        int32_t head = st[HEAD];
        if (head < 0 || head >= self->ring_frames) {
            mp_raise_ValueError(MP_ERROR_TEXT("drdy: HEAD outside the ring"));   // _isr: IndexError
        }
        int32_t nxt = head + 1;
        if (nxt == self->ring_frames) {
            nxt = 0;
        }
        if (nxt == st[TAIL]) {
            st[OVERFLOW] = next_count(st[OVERFLOW]);
        } else {
            int32_t *r = self->ring + head * SLOTS;
            r[0] = a[0];
            r[1] = a[1];
            r[2] = a[2];
            r[3] = a[3];
            r[4] = blk;
            st[HEAD] = nxt;
        }
    }
    a[0] = a[1] = a[2] = a[3] = 0;
    return mp_const_none;
}

// ****** main loop: the ring's reader (Acquisition.poll) and the survey output's sample ******

// obj.name(*args) as the VM calls it: an instance attribute first, else the class's method called
// with obj, with no bound-method object made (n <= 4)
static mp_obj_t call_attr(mp_obj_t obj, qstr name, size_t n, const mp_obj_t *args) {
    mp_obj_t call[6];
    mp_load_method(obj, name, call);        // call[0] the function, call[1] obj or MP_OBJ_NULL
    if (call[1] == MP_OBJ_NULL) {
        return mp_call_function_n_kw(call[0], n, 0, args);
    }
    // one by one: a loop becomes a memcpy, which is not linked
    if (n > 0) {
        call[2] = args[0];
    }
    if (n > 1) {
        call[3] = args[1];
    }
    if (n > 2) {
        call[4] = args[2];
    }
    if (n > 3) {
        call[5] = args[3];
    }
    return mp_call_function_n_kw(call[0], n + 1, 0, call + 1);
}

typedef struct {
    mp_obj_base_t base;
    int32_t *state;
    int32_t *ring;
    int32_t ring_frames;
    mp_obj_t arrays[2];         // state, ring: held, so their items stay alive
} drain_t;

mp_obj_full_type_t drain_type;

// Drain(acq): its state and ring (never replaced)
static mp_obj_t drain_make_new(const mp_obj_type_t *type, size_t n_args, size_t n_kw, const mp_obj_t *args) {
    mp_arg_check_num(n_args, n_kw, 1, 1, false);
    drain_t *self = mp_obj_malloc(drain_t, type);
    size_t ring_ints;
    self->arrays[0] = mp_load_attr(args[0], MP_QSTR_state);
    self->arrays[1] = mp_load_attr(args[0], MP_QSTR_ring);
    self->state = ints_of(self->arrays[0], NREADER, NULL);
    self->ring = ints_of(self->arrays[1], SLOTS, &ring_ints);
    self->ring_frames = mp_obj_get_int(mp_load_attr(args[0], MP_QSTR_ring_frames));
    if (self->ring_frames < 1 || (size_t)self->ring_frames * SLOTS > ring_ints) {
        mp_raise_ValueError(MP_ERROR_TEXT("drdy: ring_frames outside the ring"));
    }
    return MP_OBJ_FROM_PTR(self);
}

// drain(on_sample, limit=16, on_gap=None): Acquisition.poll
static mp_obj_t drain_call(mp_obj_t self_in, size_t n_args, size_t n_kw, const mp_obj_t *args) {
    if (n_args < 1 || n_args > 3 || n_kw) {
        mp_raise_TypeError(MP_ERROR_TEXT("drdy: poll takes on_sample, limit, on_gap"));
    }
    drain_t *self = MP_OBJ_TO_PTR(self_in);
    mp_obj_t on_sample = args[0];
    mp_int_t limit = n_args > 1 ? mp_obj_get_int(args[1]) : 16;
    mp_obj_t on_gap = n_args > 2 ? args[2] : mp_const_none;
    int32_t *st = self->state;
    mp_int_t n = 0;
    while (n < limit) {
        int32_t t = st[TAIL];
        if (t == st[HEAD]) {
            break;
        }
        if (t < 0 || t >= self->ring_frames) {
            mp_raise_ValueError(MP_ERROR_TEXT("drdy: TAIL outside the ring"));    // poll: IndexError
        }
        const int32_t *r = self->ring + t * SLOTS;
        mp_obj_t sample[4];
        sample[0] = mp_obj_new_int(r[0]);      // small ints (|sum| < 2^29), as the array's items
        sample[1] = mp_obj_new_int(r[1]);
        sample[2] = mp_obj_new_int(r[2]);
        sample[3] = mp_obj_new_int(r[3]);
        int32_t blk = r[4];
        t += 1;
        st[TAIL] = t == self->ring_frames ? 0 : t;     // slot free: the ISR may reuse it
        int32_t last = st[LAST];
        if (last >= 0 && blk != (last != WRAP ? last + 1 : 0)) {
            st[GAPS] = next_count(st[GAPS]);
            if (on_gap != mp_const_none) {
                mp_obj_t missing = mp_obj_new_int((blk - last - 1) & WRAP);
                mp_call_function_n_kw(on_gap, 1, 0, &missing);
            }
        }
        st[LAST] = blk;
        n++;
        st[SAMPLES] = next_count(st[SAMPLES]);
        mp_call_function_n_kw(on_sample, 4, 0, sample);
    }
    return mp_obj_new_int(n);
}

typedef struct {
    mp_obj_base_t base;
    mp_obj_t out;
    mp_obj_t survey;            // fitsums.survey, or None
} sample_t;

mp_obj_full_type_t sample_type;

// Sample(out, survey)
static mp_obj_t sample_make_new(const mp_obj_type_t *type, size_t n_args, size_t n_kw, const mp_obj_t *args) {
    mp_arg_check_num(n_args, n_kw, 2, 2, false);
    sample_t *self = mp_obj_malloc(sample_t, type);
    self->out = args[0];
    self->survey = args[1];
    return MP_OBJ_FROM_PTR(self);
}

// o.x, o.y, o.z, o.t into v[0..3]
static void held(mp_obj_t o, mp_obj_t *v) {
    v[0] = mp_load_attr(o, MP_QSTR_x);
    v[1] = mp_load_attr(o, MP_QSTR_y);
    v[2] = mp_load_attr(o, MP_QSTR_z);
    v[3] = mp_load_attr(o, MP_QSTR_t);
}

// sample(rx, ry, rz, rt): Output.sample
static mp_obj_t sample_call(mp_obj_t self_in, size_t n_args, size_t n_kw, const mp_obj_t *args) {
    if (n_args != 4 || n_kw) {
        mp_raise_TypeError(MP_ERROR_TEXT("drdy: sample takes rx, ry, rz, rt"));
    }
    sample_t *self = MP_OBJ_TO_PTR(self_in);
    mp_obj_t out = self->out, v[5];
    mp_obj_t src = mp_load_attr(out, MP_QSTR_screen);
    if (!mp_obj_is_true(call_attr(src, MP_QSTR_push, 4, args))) {
        return call_attr(out, MP_QSTR__dropped, 0, NULL);
    }
    if (mp_obj_is_true(mp_load_attr(out, MP_QSTR__delag_on))) {
        mp_obj_t dl = mp_load_attr(out, MP_QSTR_delag);
        held(src, v);
        if (!mp_obj_is_true(call_attr(dl, MP_QSTR_push, 4, v))) {
            return mp_const_none;
        }
        src = dl;
    }
    mp_obj_t session = mp_load_attr(out, MP_QSTR_session);
    if (session != mp_const_none) {
        held(src, v);
        call_attr(session, MP_QSTR_sample, 3, v);
    }
    mp_obj_t words = mp_load_attr(out, MP_QSTR__words), done = mp_const_none;
    held(src, v + 1);
    if (words != mp_const_none && self->survey != mp_const_none) {
        v[0] = words;
        done = mp_call_function_n_kw(self->survey, 5, 0, v);
    }
    if (done == mp_const_none) {    // no fitsums.survey, the float |h_c|, or past its words: in Python
        return call_attr(out, MP_QSTR__survey, 4, v + 1);
    }
    if (!mp_obj_is_true(done)) {
        return mp_const_none;
    }
    mp_obj_t blk = call_attr(mp_load_attr(out, MP_QSTR_survey), MP_QSTR_finish, 0, NULL);
    return call_attr(out, MP_QSTR__output, 1, &blk);
}

static void make_type(mp_obj_full_type_t *type, qstr name, void *make_new, void *call) {
    type->base.type = (void *)&mp_type_type;
    type->flags = MP_TYPE_FLAG_NONE;
    type->name = name;
    MP_OBJ_TYPE_SET_SLOT(type, make_new, make_new, 0);
    MP_OBJ_TYPE_SET_SLOT(type, call, call, 1);
    mp_store_global(name, MP_OBJ_FROM_PTR(type));
}

mp_obj_t mpy_init(mp_obj_fun_bc_t *self, size_t n_args, size_t n_kw, mp_obj_t *args) {
    MP_DYNRUNTIME_INIT_ENTRY
    make_type(&handler_type, MP_QSTR_Handler, handler_make_new, handler_call);
    make_type(&drain_type, MP_QSTR_Drain, drain_make_new, drain_call);
    make_type(&sample_type, MP_QSTR_Sample, sample_make_new, sample_call);
    MP_DYNRUNTIME_INIT_EXIT
}
