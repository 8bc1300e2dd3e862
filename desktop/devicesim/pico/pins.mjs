// The simulated world on the emulated Pico's pins: two ADS1292 on SPI0, their DRDY, START and
// RESET, the button and the LED (device/config.py's pin map). The chips are desktop/sim's model in
// the Python process (desktop/devicesim/pico_world.py); this is the runner's end of the bridge.
//
// Why a bridge with frames handed ahead (../shared/rp2/SOURCE.md): the SPI answers a byte one
// byte-time after it is sent, on the emulated clock, so the answer must be here when that alarm
// fires. Two ways are used:
//  - a frame read (RDATAC, the firmware sends zeros) is answered here from the frame Python sent
//    with its last reply, valid until that chip's next conversion; the bytes read are reported
//    afterwards ('R'), and Python clocks them through the model (which must answer the same);
//  - anything else (a command, a register, a read after the frame went stale) pauses the core
//    while the byte goes to Python and back ('S'): no emulated time passes meanwhile.
// The button, START/RESET edges and the world's news are requests too ('T', 'P'): the core waits
// for the world's answer, which names the next time the world has news (at most 10 ms on) and
// lists chip 0's DRDY falls before it; this makes those edges on its own clock (a fall needs no
// world state: it is the chips' schedule), so a conversion costs a round trip only when the
// firmware reads its frame ('T' at the first byte of a read whose frame is stale).
//
// Messages to Python (fd 4): 16 bytes "<BBHxxxxd": type, a, b, emulated ns.
//   B boot | T tick (reply) | S mask,byte (reply) | R mask,n | E (CS high) | P gpio,level (reply
//   for START and RESET).
// Replies (fd 3): 186 bytes "<BB6xddd9s9sB7x16d": miso, flags (1 DRDY low, 2 DRDY fell, 4 button
//   pressed), next event ns, frame 0 valid until ns, frame 1 valid until ns, frame 0, frame 1,
//   n, the ns of the next n DRDY falls (before the next event).
import fs from 'node:fs';
import net from 'node:net';

const CS = [17, 20], DRDY = 21, START = 22, RESET = 26, BUTTON = 15, LED = 25;
const MSG = 16, REPLY = 186, FALLS = 16;
const LOW = 0, HIGH = 1;                  // GPIOPinState of an output

export class WorldBridge {
  constructor(inFd, outFd, control) {
    this.outFd = outFd;
    this.control = control;               // { pause(), resume(), end() }: the runner's core
    this.queued = [];                     // messages not yet written (written before any request)
    this.waiting = [];                    // callbacks of the requests in flight, in order
    this.pending = Buffer.alloc(0);
    this.frames = [Buffer.alloc(9), Buffer.alloc(9)];
    this.validUntil = [-1, -1];
    // latency: DRDY's fall to the first SCLK of chip 0's read (emulated ns; latencyMaxNs the worst
    // since the last figures()); unread: conversions whose frame was not read before the next fell
    this.stats = { requests: 0, local: 0, lockstep: 0, fetches: 0, falls: 0, waitMs: 0, reads: 0,
      latencySumNs: 0, latencyMaxNs: 0, unread: 0 };
    this.falls = [];                      // the ns of the DRDY falls handed ahead, next first
    this.fellAt = null;
    this.asked = 0;
    // a socket on the pipe, not fs.createReadStream: that one blocks a libuv thread in read(),
    // and process.exit() waits for it, so the runner could not end
    new net.Socket({ fd: inFd, readable: true, writable: false }).on('data', (d) => this.onReply(d))
      .on('end', () => control.end());    // the world is gone: so is the board
  }

  figures() {                              // the counts now; the worst latency starts again
    const f = { ...this.stats };
    this.stats.latencyMaxNs = 0;
    return f;
  }

  // ****** the pipe ******
  message(type, a, b, t) {
    const m = Buffer.alloc(MSG);
    m.writeUInt8(type.charCodeAt(0), 0);
    m.writeUInt8(a, 1);
    m.writeUInt16LE(b, 2);
    m.writeDoubleLE(t, 8);
    this.queued.push(m);
  }

  flush() {
    if (!this.queued.length) return;
    const all = Buffer.concat(this.queued);
    this.queued = [];
    for (let off = 0; off < all.length;) {
      try { off += fs.writeSync(this.outFd, all, off); } catch (e) { if (e.code !== 'EAGAIN') throw e; }
    }
  }

  request(type, a, b, then) {              // the core pauses until the world answers
    this.message(type, a, b, this.clock.nanos);
    this.flush();
    this.stats.requests++;
    if (!this.waiting.length) this.asked = performance.now();
    this.waiting.push(then);
    this.control.pause();
  }

  onReply(data) {
    this.pending = Buffer.concat([this.pending, data]);
    while (this.pending.length >= REPLY && this.waiting.length) {
      const r = this.pending.subarray(0, REPLY);
      this.pending = this.pending.subarray(REPLY);
      this.apply(r);
      this.waiting.shift()(r.readUInt8(0));
    }
    if (!this.waiting.length) {
      this.stats.waitMs += performance.now() - this.asked;
      this.control.resume();
    }
  }

  // a new conversion: a falling edge, as on the pin
  fall() {
    this.mcu.gpio[DRDY].setInputValue(true);
    this.mcu.gpio[DRDY].setInputValue(false);
    if (this.fellAt !== null) this.stats.unread++;
    this.fellAt = this.clock.nanos;
  }

  fallAhead() {                                  // the next of the falls handed ahead
    this.stats.falls++;
    this.falls.shift();
    this.fall();
    this.scheduleFall();
  }

  scheduleFall() {
    if (this.falls.length) this.fallAlarm.schedule(Math.max(0, this.falls[0] - this.clock.nanos));
    else this.fallAlarm.cancel();
  }

  apply(r) {
    const flags = r.readUInt8(1);
    const drdy = this.mcu.gpio[DRDY];
    if (flags & 2) this.fall();
    // the pin falls only with an edge (a conversion): low in the world while high here is a
    // read whose first SCLK the model has not seen yet (the frame fetched for it)
    if (!(flags & 1)) drdy.setInputValue(true);
    this.mcu.gpio[BUTTON].setInputValue(!(flags & 4));   // to ground when pressed
    this.worldAlarm.schedule(Math.max(0, r.readDoubleLE(8) - this.clock.nanos));
    for (let k = 0; k < 2; k++) {
      this.validUntil[k] = r.readDoubleLE(16 + 8 * k);
      r.copy(this.frames[k], 0, 32 + 9 * k, 41 + 9 * k);
    }
    this.falls = [];
    for (let i = 0; i < Math.min(r.readUInt8(50), FALLS); i++) this.falls.push(r.readDoubleLE(58 + 8 * i));
    this.scheduleFall();
  }

  // ****** a new chip (power on, reset): wire it ******
  attach(mcu, clock) {
    this.mcu = mcu;
    this.clock = clock;
    // a request still in flight belongs to the chip that was: its reply comes back in order and
    // is read past. Dropping the queue instead would pair every later reply with the request
    // before it (a power cycle then read the chip IDs as 0x00).
    this.waiting = this.waiting.map(() => () => {});
    this.validUntil = [-1, -1];
    this.fellAt = null;
    this.txn = null;                      // the SPI transaction in progress: { mask, n, local }
    mcu.gpio[DRDY].setInputValue(true);
    mcu.gpio[BUTTON].setInputValue(true);
    this.worldAlarm = clock.createAlarm(() => this.request('T', 0, 0, () => {}));
    this.falls = [];
    this.fallAlarm = clock.createAlarm(() => this.fallAhead());
    for (const pin of CS) mcu.gpio[pin].addListener(() => this.onChipSelect());
    for (const pin of [START, RESET]) {
      mcu.gpio[pin].addListener((state) => {
        if (state === LOW || state === HIGH) this.request('P', pin, state === HIGH ? 1 : 0, () => {});
      });
    }
    mcu.gpio[LED].addListener((state) => {
      if (state === LOW || state === HIGH) this.message('P', LED, state === HIGH ? 1 : 0, clock.nanos);
    });
    const spi = mcu.spi[0];
    spi.onTransmit = (byte) => this.onByte(spi, byte);
    this.message('B', 0, 0, 0);
    this.request('T', 0, 0, () => {});    // the world's levels before the first instruction
  }

  chipMask() {
    return CS.reduce((m, pin, k) => m | (this.mcu.gpio[pin].outputValue ? 0 : 1 << k), 0);
  }

  onChipSelect() {
    const mask = this.chipMask();
    if (this.txn && mask === this.txn.mask) return;
    this.endTransaction();
    if (mask) this.txn = { mask, n: 0, local: true };
  }

  endTransaction() {
    const txn = this.txn;
    this.txn = null;
    if (!txn) return;
    if (txn.local && txn.n) this.message('R', txn.mask, txn.n, txn.t0);
    this.message('E', txn.mask, 0, this.clock.nanos);
  }

  onByte(spi, byte) {
    const done = (miso) => {
      const alarm = this.clock.createAlarm(() => spi.completeTransmit(miso));
      alarm.schedule(8e9 / spi.clockFrequency);    // one byte-time on SCLK
    };
    this.mcu.gpio[DRDY].setInputValue(true);       // the first SCLK edge raises DRDY [DS 8.5.1.6]
    const txn = this.txn;
    const k = txn ? [0, 1].find((i) => txn.mask === 1 << i) : undefined;
    if (k === 0 && this.fellAt !== null) {        // the firmware's answer to DRDY: its read of chip 0
      const latency = this.clock.nanos - this.fellAt;
      this.stats.reads++;
      this.stats.latencySumNs += latency;
      this.stats.latencyMaxNs = Math.max(this.stats.latencyMaxNs, latency);
      this.fellAt = null;
    }
    if (txn && txn.local && k !== undefined && byte === 0 && txn.n === 0 && this.clock.nanos >= this.validUntil[k]
        && this.fetchedAt !== this.clock.nanos) {
      // a read of a conversion made here (its frame not yet in hand): the world's frames now
      this.stats.fetches++;
      this.fetchedAt = this.clock.nanos;
      this.request('T', 0, 0, () => this.onByte(spi, byte));
      return;
    }
    if (txn && txn.local && k !== undefined && byte === 0 && this.clock.nanos < this.validUntil[k]) {
      if (txn.n === 0) txn.t0 = this.clock.nanos;
      done(this.frames[k][txn.n++ % 9]);
      this.stats.local++;
      return;
    }
    if (txn && txn.local && txn.n) this.message('R', txn.mask, txn.n, txn.t0);   // what went before
    if (txn) txn.local = false;
    this.stats.lockstep++;
    this.request('S', txn ? txn.mask : 0, byte, done);
  }
}
