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
#define NSTATE (11)
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

mp_obj_t mpy_init(mp_obj_fun_bc_t *self, size_t n_args, size_t n_kw, mp_obj_t *args) {
    MP_DYNRUNTIME_INIT_ENTRY
    handler_type.base.type = (void *)&mp_type_type;
    handler_type.flags = MP_TYPE_FLAG_NONE;
    handler_type.name = MP_QSTR_Handler;
    MP_OBJ_TYPE_SET_SLOT(&handler_type, make_new, handler_make_new, 0);
    MP_OBJ_TYPE_SET_SLOT(&handler_type, call, handler_call, 1);
    mp_store_global(MP_QSTR_Handler, MP_OBJ_FROM_PTR(&handler_type));
    MP_DYNRUNTIME_INIT_EXIT
}
