// An emulated Raspberry Pi Pico: MicroPython's rp2 firmware in rp2040js, with its flash in a file.
//
//   node runner.mjs --modules NODE_MODULES --firmware firmware.bin --bootrom rp2040-bootrom-B1.bin
//                   --flash pico.flash [--idle paced|jump] [--high 15,21] [--world R,W]
//
// NODE_MODULES holds rp2040js (npm ci under build/, desktop/firmware/interpreters.py); --high:
// the GPIOs the host holds high from power-on (pull-ups are not modelled); --world: the simulated
// chips, button and LED on the pins, over fds R (from the world) and W (to it): pins.mjs.
//
// stdin is what the host sends on the board's USB CDC, stdout what the board sends back (the
// Python side, desktop/devicesim/pico_board.py, puts them on a pseudo-terminal); stderr carries
// one line per event ("pico: ..."). EOF on stdin, SIGTERM or SIGINT save the flash and exit;
// SIGUSR2 is a power cycle (the chip re-created with its flash).
//
// What stock rp2040js 1.4.1 needs from a runner (../shared/rp2/SOURCE.md, "Four things"):
//  1. USB OUT: its USBCDC answers every armed host-to-board buffer at once with an empty packet
//     (an interrupt every ~10 us, Python 3x slower); here the transfer is held until the host has bytes.
//  2. Simulator.execute spins when the core sleeps with nothing pending; this loop yields to Node.
//  3. Idle time is either paced to the wall clock (--idle paced: a person, mpremote's 1 s polls)
//     or jumped to the next timer (--idle jump: tests and benches).
//  4. The watchdog (machine.reset() uses it) has no reset action: the chip is re-created here,
//     with the watchdog's REASON register kept (TIMER or FORCE, as through a real watchdog reset).
//     Its count running out (machine.WDT not fed) re-armed its alarm at 0 ns forever: stopped here.
//  5. PIO: rp2040js runs a PIO block in setTimeout slices of 1000 instructions, apart from the
//     emulated clock, and steps disabled state machines too; here the enabled ones run when
//     something they wait on may have changed (an input pin, the block's registers, its FIFOs,
//     CTRL) until each waits again: pioOnEvents below.
//  6. Speed (decoder.mjs): the core's instruction decode indexed by the opcode's top five bits and
//     SRAM stores before the peripheral lookup; the same instructions and cycles, 1.2-1.3x faster.
// The flash is made writable by patching the boot ROM's flash_range_erase / flash_range_program
// to BKPT and doing the erase (fill 0xff) and program (AND, as NOR flash) in onBreak (bootrom.mjs).
import fs from 'node:fs';
import path from 'node:path';
import { pathToFileURL } from 'node:url';

const FLASH_SIZE = 2 * 1024 * 1024;      // RPI_PICO's W25Q16: firmware, then littlefs from 0xa0000
const FLASH_BASE = 0x10000000;
const FS_OFFSET = 0xa0000, FS_BLOCK = 4096;  // RPI_PICO's filesystem: 1408 KiB of 4 KiB blocks
const CYCLE_NS = 8;                      // 125 MHz: clk_sys until the firmware sets the PLL
const BATCH = 20000;                     // instructions between looks at the host and the wall clock
const SLICE_MS = 20;                     // longest run without yielding to Node (host bytes, signals)
const LAG_NS = 50e6;                     // paced: emulated time may trail the wall clock by this much

const args = Object.fromEntries(process.argv.slice(2).reduce((acc, a, i, all) =>
  (a.startsWith('--') ? acc.concat([[a.slice(2), all[i + 1]]]) : acc), []));
const idleMode = args.idle || 'paced';
const say = (msg) => process.stderr.write(`pico: ${msg}\n`);
const esm = (file) => import(pathToFileURL(path.join(args.modules, 'rp2040js', 'dist', 'esm', file)).href);
const { RP2040, USBCDC } = await esm('index.js');
const { SimulationClock } = await esm('clock/simulation-clock.js');
const { WorldBridge } = args.world ? await import('./pins.mjs') : {};
const { Parts } = await import('./parts.mjs');
const { patchedBootrom, flashOp: flashWrite } = await import('./bootrom.mjs');
const { RPPIO } = await esm('peripherals/pio.js');
const { GPIOPin } = await esm('gpio-pin.js');
const { CortexM0Core } = await esm('cortex-m0-core.js');
const { MAX_HARDWARE_IRQ } = await esm('irq.js');
const { APB_START_ADDRESS, SIO_START_ADDRESS, RAM_START_ADDRESS } = await esm('rp2040.js');
const { indexDecoder, sramFirst } = await import('./decoder.mjs');
indexDecoder(path.join(args.modules, 'rp2040js', 'dist', 'esm', 'cortex-m0-core.js'), CortexM0Core,
  { MAX_HARDWARE_IRQ, APB_START_ADDRESS, SIO_START_ADDRESS }, say);
sramFirst(RP2040, RAM_START_ADDRESS);

// ****** the flash file: the whole 2 MiB, firmware image rewritten at each start ******
function loadFlash() {
  const image = new Uint8Array(FLASH_SIZE).fill(0xff);
  let kept = null;
  try { kept = fs.readFileSync(args.flash); } catch { /* a new board: empty flash */ }
  if (kept && kept.length !== FLASH_SIZE) {
    say(`flash file ${args.flash} is ${kept.length} bytes, not ${FLASH_SIZE}: the rest reads as erased`);
  }
  if (kept) image.set(kept.subarray(0, FLASH_SIZE));
  if (kept && !hasLittlefs(image)) {
    say(`flash file ${args.flash} holds no littlefs at 0x${FS_OFFSET.toString(16)}: the firmware formats it at boot`);
  }
  const firmware = fs.readFileSync(args.firmware);
  image.fill(0xff, 0, FS_OFFSET);          // the firmware's region, then the image itself
  image.set(firmware, 0);
  return image;
}

// littlefs keeps its superblock in blocks 0 and 1, the name "littlefs" 8 bytes into the block
function hasLittlefs(image) {
  const magic = Buffer.from('littlefs');
  return [0, FS_BLOCK].some((b) => Buffer.from(image.subarray(FS_OFFSET + b + 8, FS_OFFSET + b + 16)).equals(magic));
}

let flash = loadFlash();
let saveTimer = null;
function saveFlash() {                   // atomic: the old file stays until the new one is whole
  if (saveTimer) { clearTimeout(saveTimer); saveTimer = null; }
  fs.writeFileSync(args.flash + '.tmp', flash);
  fs.renameSync(args.flash + '.tmp', args.flash);
}
function saveSoon() {                    // one save per batch of erases/programs, not per page
  if (!saveTimer) saveTimer = setTimeout(saveFlash, 100);
}

// ****** the boot ROM, its flash write functions turned into breakpoints (bootrom.mjs) ******
const bootrom = patchedBootrom(args.bootrom);

// ****** the host's bytes, held until the board arms a USB OUT buffer (thing 1) ******
const fromHost = [];                     // Buffers not yet handed to the board
let pendingOut = null;                   // the size of the OUT buffer the board armed, or null
let mcu, cdc, clock, resetAsked = null, resetReason = 0;
// emulated ns per instruction cycle: clk_sys as rp2040js derives it from the PLL and CLOCKS
// registers, so machine.freq() gives the firmware fewer (or more) cycles per emulated second
let cycleNs = CYCLE_NS;

function offerHostBytes() {
  if (pendingOut === null || fromHost.length === 0 || cdc.outEndpoint < 0) return;
  const out = new Uint8Array(pendingOut);
  let n = 0;
  while (n < out.length && fromHost.length) {
    const head = fromHost[0];
    const take = Math.min(head.length, out.length - n);
    out.set(head.subarray(0, take), n);
    n += take;
    if (take === head.length) fromHost.shift(); else fromHost[0] = head.subarray(take);
  }
  pendingOut = null;
  mcu.usbCtrl.endpointReadDone(cdc.outEndpoint, out.subarray(0, n));
}

const NOISE = /^Unimplemented peripheral|invalid SIO address:? (0x)?5[08]|address:? 1400[02]00[04]/;
console.warn = (msg) => { if (!NOISE.test(msg)) say(msg); };     // rp2040js's SIO warns on the console

function createChip(why) {
  clock = new SimulationClock(125e6);
  mcu = new RP2040(clock);
  cycleNs = 1e9 / mcu.clkSys;
  mcu.addClockListener((hz) => { cycleNs = 1e9 / hz; });
  mcu.logger = {
    debug() {}, info() {},
    // noise: one core is emulated (core 1's FIFO at SIO 0x50/0x58, SOURCE.md); the XIP cache's
    // control registers (0x14000000, flushed after each flash write) and the clock, syscfg and
    // voltage-regulator registers MicroPython sets up at boot are not modelled
    warn(name, msg) { if (!NOISE.test(msg)) say(`${name}: ${msg}`); },
    error(name, msg) { if (!NOISE.test(msg)) say(`${name}: ${msg}`); },
  };
  mcu.loadBootrom(bootrom);              // this resets the chip, which erases its flash: load it after
  mcu.flash.set(flash);
  flash = mcu.flash.subarray(0, FLASH_SIZE);
  // start at the image's boot2, as the boot ROM does once it has found it in flash (the ROM's
  // own start-up waits on things rp2040js does not model; its functions are still called)
  mcu.core.PC = FLASH_BASE;
  mcu.onBreak = (code) => flashOp(code);
  const watchdog = mcu.peripherals[0x40058];
  watchdog.reason = resetReason;         // REASON survives the watchdog's own reset, not a power cycle
  watchdog.onWatchdogTrigger = () => {
    // rp2040js re-arms its periodic alarm at once when the count reaches 0 (an endless loop inside
    // clock.tick): the chip stops here, as the real one does when the watchdog resets it
    watchdog.alarm.enable = false;
    resetReason = watchdog.reason;       // TIMER (1): the count ran out; FORCE (2): machine.reset()
    resetAsked = resetReason & 1 ? 'watchdog timeout' : 'watchdog';
  };
  cdc = new USBCDC(mcu.usbCtrl);
  cdc.onSerialData = (bytes) => process.stdout.write(Buffer.from(bytes));
  pendingOut = null;
  const armed = mcu.usbCtrl.onEndpointRead;
  mcu.usbCtrl.onEndpointRead = (endpoint, size) => {
    if (endpoint !== cdc.outEndpoint) return armed(endpoint, size);
    pendingOut = size;
    offerHostBytes();
  };
  // power on: the bus hands every GPIO's input its idle level before the firmware runs
  for (const [pin, level] of Object.entries(inputLevels)) mcu.gpio[pin].setInputValue(level);
  asleepNs = 0;
  parts.attach(mcu);
  anchor();
  say(`boot (${why})`);
  if (world) world.attach(mcu, clock);
}

// a breakpoint: the boot ROM's flash_range_erase or _program done (bootrom.mjs), saved soon after
function flashOp(code) {
  if (!flashWrite(mcu, flash, code)) {
    say(`breakpoint ${code} at 0x${(mcu.core.PC - 2).toString(16)}: the firmware stopped`);
    return;
  }
  saveSoon();
}

// ****** thing 5: PIO in step with the emulated clock ******
// A state machine's program between two waits takes nanoseconds at clk_sys; it is run to its next
// wait at once, when an input level changes (fluxcal's DRDY counter waits on DRDY's edges: a fall
// here sets the pin high and low at the same instant, and each level is seen) or the core touches
// the block. A program that does not wait within PIO_SETTLE instructions runs free on real
// hardware, which this runner does not model: it is stopped, with a line on stderr.
const PIO_SETTLE = 256;
function settlePio(pio) {
  if (pio.stopped) return;
  const machines = pio.machines.filter((m) => m.enabled);
  for (let i = 0; i < PIO_SETTLE; i++) {
    let waiting = true;
    for (const m of machines) {
      m.step();
      if (m.waiting) m.checkWait();
      waiting &&= m.waiting;
    }
    pio.checkChangedPins();
    if (waiting) return;
  }
  say(`PIO${pio.index}: a state machine ran ${PIO_SETTLE} instructions without waiting: stopped (this runner runs PIO between waits only)`);
  pio.stop();
}
function pioOnEvents() {
  RPPIO.prototype.run = function run() { settlePio(this); };     // CTRL enabled a machine
  for (const name of ['readUint32', 'writeUint32']) {
    const access = RPPIO.prototype[name];
    RPPIO.prototype[name] = function (offset, value) {
      const result = access.call(this, offset, value);
      settlePio(this);
      return result;
    };
  }
  const setInput = GPIOPin.prototype.setInputValue;
  GPIOPin.prototype.setInputValue = function (value) {
    setInput.call(this, value);
    for (const pio of this.rp2040.pio) settlePio(pio);
  };
}
pioOnEvents();

// ****** the pins the host drives (the button, DRDY...): level kept across resets ******
const inputLevels = {};
for (const pin of (args.high || '').split(',').filter(Boolean)) inputLevels[pin] = true;

// ****** the loop: run, yield, idle (things 2 and 3) ******
let asleepNs = 0;                        // since power-on: cycles awake = (clock.nanos - asleepNs) / 8
const parts = new Parts(() => clock.nanos - asleepNs);   // the awake cycles by part (parts.mjs)
let anchorWall = 0, anchorEmu = 0, idleTimer = null, sleeping = false, paused = false, scheduled = false;
const world = args.world ? new WorldBridge(...args.world.split(',').map(Number), {
  pause() { paused = true; },
  resume() { paused = false; wake(); },
  end() { quit(0); },
}) : null;
function anchor() { anchorWall = performance.now(); anchorEmu = clock.nanos; }
function wallNanos() { return anchorEmu + (performance.now() - anchorWall) * 1e6; }

function run() {
  idleTimer = null;
  sleeping = false;
  scheduled = false;
  const until = performance.now() + SLICE_MS;
  while (performance.now() < until && !paused) {
    if (resetAsked) {                    // thing 4: machine.reset() and the watchdog
      const why = resetAsked;
      resetAsked = null;
      createChip(why);
    }
    const core = mcu.core;
    for (let i = 0; i < BATCH && !resetAsked && !paused; i++) {
      if (!core.waiting) {
        clock.tick(core.executeInstruction() * cycleNs);
        continue;
      }
      if (!clock.nextAlarm) {            // asleep with nothing due: wait for the host
        if (idleMode === 'paced') sleep(Math.max(0, wallNanos() - clock.nanos));
        sleeping = true;
        world?.flush();
        return;
      }
      const due = clock.nextAlarm.nanos;
      if (idleMode === 'paced') {
        const wall = wallNanos();
        if (wall - clock.nanos > LAG_NS) { anchorEmu = clock.nanos; anchorWall = performance.now(); }
        else if (due > wall) {           // spend the idle time as wall time
          idleTimer = setTimeout(run, Math.min(SLICE_MS, (due - wall) / 1e6));
          world?.flush();
          return;
        }
      }
      sleep(due - clock.nanos);
    }
  }
  world?.flush();
  if (!paused) schedule();              // else the world's answer resumes it
}

// the core asleep (WFI/WFE) for ns: emulated time that costs no cycles (the load figures)
function sleep(ns) {
  asleepNs += ns;
  clock.tick(ns);
}

function schedule() {
  if (!scheduled) { scheduled = true; setImmediate(run); }
}

// the host (or a pin) has news for a board that waits: run now
function wake() {
  if (idleTimer) { clearTimeout(idleTimer); idleTimer = null; }
  sleeping = false;
  if (!paused) schedule();              // a spare run() only looks again and returns
}

function quit(code) {
  saveFlash();
  process.exit(code);
}

process.stdin.on('data', (chunk) => { fromHost.push(chunk); offerHostBytes(); wake(); });
process.stdin.on('end', () => quit(0));
process.on('SIGTERM', () => quit(0));
process.on('SIGINT', () => quit(0));
process.on('SIGUSR2', () => { saveFlash(); resetReason = 0; createChip('power cycle'); wake(); });
// SIGUSR1: one line of figures (pico_board.PicoBoard.figures): emulated ns since power-on, of
// which asleep, clk_sys (Hz), the awake cycles by part, and the bridge's counts
process.on('SIGUSR1', () => say(`figures ${JSON.stringify({ ns: clock.nanos, asleep_ns: asleepNs, clk_sys_hz: mcu.clkSys,
  wall_ms: performance.now(), parts: parts.figures(), bridge: world?.figures() ?? null })}`));
process.stdout.on('error', () => quit(0));   // the host side is gone

createChip('power on');
schedule();
// PICO_DEBUG=1: where the core is, once a wall second (a firmware that hangs, a wait that never ends)
if (process.env.PICO_DEBUG) setInterval(() => say(`${JSON.stringify(world?.stats)} t=${(clock.nanos / 1e9).toFixed(4)} pc=0x${mcu.core.PC.toString(16)} waiting=${mcu.core.waiting} sleeping=${sleeping} pendingOut=${pendingOut} ep=${cdc.outEndpoint} alarm=${!!clock.nextAlarm}`), 1000);
