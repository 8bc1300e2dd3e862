// The indexed decoder (desktop/devicesim/pico/decoder.mjs) against rp2040js's own core:
//
//   node decoder_check.mjs NODE_MODULES firmware.bin bootrom.bin INSTRUCTIONS SNIPPET
//
// 1. Every 16-bit opcode (and, for the 32-bit encodings, second halfwords that reach each test on
//    opcode2): the first branch of rp2040js's chain whose test holds must be the first of its
//    bucket's branches that holds.
// 2. Two chips booting the rp2 firmware, one with each core, the same SNIPPET typed at the REPL
//    of both: after every instruction the PC, registers, flags, cycles and emulated time must be
//    the same; at the end SRAM and what each sent on USB too.
// Prints one JSON line.
import fs from 'node:fs';
import path from 'node:path';
import { pathToFileURL } from 'node:url';

const [modules, firmware, bootromFile, count, snippet] = process.argv.slice(2);
const esm = (file) => import(pathToFileURL(path.join(modules, 'rp2040js', 'dist', 'esm', file)).href);
const { RP2040, USBCDC } = await esm('index.js');
const { SimulationClock } = await esm('clock/simulation-clock.js');
const { MAX_HARDWARE_IRQ } = await esm('irq.js');
const { APB_START_ADDRESS, SIO_START_ADDRESS } = await esm('rp2040.js');
const here = path.dirname(new URL(import.meta.url).pathname);
const pico = (file) => import(pathToFileURL(path.join(here, '..', '..', 'desktop', 'devicesim', 'pico', file)).href);
const { indexedCore } = await pico('decoder.mjs');
const { patchedBootrom, flashOp } = await pico('bootrom.mjs');  // as runner.mjs: the flash writable
const coreFile = path.join(modules, 'rp2040js', 'dist', 'esm', 'cortex-m0-core.js');
const indexed = indexedCore(coreFile, { MAX_HARDWARE_IRQ, APB_START_ADDRESS, SIO_START_ADDRESS });

// 1. the branch each opcode takes
const tests = indexed.chain.branches.map((b) => new Function('opcode', 'opcode2', `return !!(${b.cond});`));
const first = (ks, op, op2) => { for (const k of ks) if (tests[k](op, op2)) return k; return -1; };
const all = tests.map((_, k) => k);
// opcode2: each top byte (the tests' opcode2 >> 8, >> 12, >> 14), and DMB, DSB, ISB's low bytes
const seconds = [0x8f40, 0x8f4f, 0x8f5f, 0x8f60, 0x8f6f, 0x8f70];
for (let hi = 0; hi < 256; hi++) for (const lo of [0x00, 0x50]) seconds.push((hi << 8) | lo);
let opcodes = 0, wrong = 0;
for (let op = 0; op < 0x10000; op++) {
  const top = op >> 11;
  const wide = top >= 0b11101;          // rp2040js reads opcode2 only for these; 0 otherwise
  for (const op2 of wide ? seconds : [0]) {
    opcodes++;
    if (first(all, op, op2) !== first(indexed.plan[top], op, op2)) wrong++;
  }
}

// 2. two chips in step
const rom = patchedBootrom(bootromFile);
const image = new Uint8Array(2 * 1024 * 1024).fill(0xff);
image.set(fs.readFileSync(firmware), 0);
console.warn = () => {};

function chip(execute) {
  const clock = new SimulationClock(125e6);
  const mcu = new RP2040(clock);
  mcu.logger = { debug() {}, info() {}, warn() {}, error() {} };
  mcu.loadBootrom(rom);
  mcu.flash.set(image);
  mcu.core.PC = 0x10000000;
  if (execute) mcu.core.executeInstruction = execute;
  const flash = mcu.flash;
  mcu.onBreak = (code) => flashOp(mcu, flash, code);
  const cdc = new USBCDC(mcu.usbCtrl);
  const board = { mcu, clock, out: '', typed: false, cycleNs: 8 };
  cdc.onSerialData = (bytes) => { board.out += Buffer.from(bytes).toString('latin1'); };
  cdc.onDeviceConnected = () => cdc.sendSerialByte(13);      // a prompt, whatever the banner did
  board.type = () => {                  // at the REPL's first prompt
    if (!board.typed && board.out.includes('>>> ')) {
      board.typed = true;
      for (const c of `${snippet}\r`) cdc.sendSerialByte(c.charCodeAt(0));
    }
  };
  mcu.addClockListener((hz) => { board.cycleNs = 1e9 / hz; });
  return board;
}

// one instruction, or the sleep to the next alarm; false when asleep with nothing due
function step(b) {
  const core = b.mcu.core;
  if (!core.waiting) { b.clock.tick(core.executeInstruction() * b.cycleNs); return true; }
  if (!b.clock.nextAlarm) return false;
  b.clock.tick(b.clock.nextAlarm.nanos - b.clock.nanos);
  return true;
}

const same = (a, b) => {
  const x = a.mcu.core, y = b.mcu.core;
  if (x.PC !== y.PC || x.N !== y.N || x.Z !== y.Z || x.C !== y.C || x.V !== y.V || x.cycles !== y.cycles) return false;
  if (a.clock.nanos !== b.clock.nanos || x.waiting !== y.waiting) return false;
  for (let r = 0; r < 16; r++) if (x.registers[r] !== y.registers[r]) return false;
  return true;
};

const stock = chip(null), fast = chip(indexed.executeInstruction);
let steps = 0, differed = 0;
while (steps < Number(count)) {
  if ((steps & 0xfff) === 0) { stock.type(); fast.type(); }
  const a = step(stock), b = step(fast);
  steps++;
  if (a !== b || !same(stock, fast)) { differed = steps; break; }
  if (!a) break;
}
const sramSame = Buffer.compare(Buffer.from(stock.mcu.sram), Buffer.from(fast.mcu.sram)) === 0;
console.log(JSON.stringify({ opcodes, wrong, branches: tests.length, steps, differed, sram_same: sramSame,
  usb_same: stock.out === fast.out, typed: stock.typed, out: fast.out.slice(-200), emulated_ms: fast.clock.nanos / 1e6 }));
