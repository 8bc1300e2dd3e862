// Where the emulated core's cycles go: counted by the runner, outside emulated time, so the
// counting itself costs the firmware no cycle.
//
// - Exceptions: every cycle between an exception's entry and its return is charged to that
//   exception ('irq29' is IRQ 13, IO_IRQ_BANK0: the DRDY handler, hard IRQ, its SPI reads
//   included; 'irq21' USB; 'irq14' PendSV; 'irq16'.. the timer alarms). A nested one is charged
//   to the inner exception only.
// - Thread mode: charged to the part the firmware last named by writing its number to the
//   profiling port (PORT, 'part0' until one is named). Nothing in the firmware writes there:
//   desktop/bench/micropython-scripts/pico_parts.py wraps the firmware's functions to do it
//   (machine.mem32[0x40068000] = n | ENTRY on the way in, the number read back before it on
//   the way out), and says what that costs.
// - Asleep (WFI/WFE) is no part: the runner's asleep count.
// figures() -> { cycles: { key: cycles }, calls: { key: entries } } since power-on.

// An APB slot the RP2040 leaves empty (between VREG_AND_CHIP_RESET and TBMAN): on a board a
// write there is a bus fault, so only a script run for this emulator writes it.
export const PORT = 0x40068000;
const CYCLE_NS = 8;                        // 125 MHz
const ENTRY = 0x100;                       // a write with this bit set enters the part: one call

export class Parts {
  constructor(awakeNs) {
    this.awakeNs = awakeNs;                // () -> emulated ns awake since power-on
    this.cycles = {};
    this.calls = {};
  }

  attach(mcu) {
    const core = mcu.core;
    this.cycles = {};
    this.calls = {};
    this.part = 0;
    this.stack = [];                       // the exceptions active, innermost last
    this.since = this.awakeNs();
    const entry = core.exceptionEntry, leave = core.exceptionReturn;
    core.exceptionEntry = (n) => {
      this.charge();
      this.stack.push(n);
      this.calls[`irq${n}`] = (this.calls[`irq${n}`] || 0) + 1;
      entry.call(core, n);
    };
    core.exceptionReturn = (r) => { this.charge(); this.stack.pop(); leave.call(core, r); };
    const parts = this;
    mcu.peripherals[PORT >>> 12] = {
      readUint32() { return parts.part; },
      writeUint32Atomic(offset, value) {
        parts.charge();
        parts.part = value & ~ENTRY;
        if (value & ENTRY) parts.calls[`part${parts.part}`] = (parts.calls[`part${parts.part}`] || 0) + 1;
      },
    };
  }

  charge() {
    const now = this.awakeNs();
    const key = this.stack.length ? `irq${this.stack[this.stack.length - 1]}` : `part${this.part}`;
    this.cycles[key] = (this.cycles[key] || 0) + (now - this.since) / CYCLE_NS;
    this.since = now;
  }

  figures() {
    this.charge();
    return { cycles: this.cycles, calls: this.calls };
  }
}
