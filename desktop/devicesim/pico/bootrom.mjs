// The RP2040 boot ROM with its flash write functions turned into breakpoints, and what a
// breakpoint does to the flash: rp2040js models the flash as memory the core reads (XIP) but
// not the QSPI commands that erase and program it, so MicroPython's rp2.Flash writes reach the
// ROM's flash_range_erase / flash_range_program, which stop here instead (../shared/rp2/SOURCE.md:
// "Flash is read-only in stock rp2040js"). Used by runner.mjs and tests/pico/decoder_check.mjs.
import fs from 'node:fs';

export const BKPT_ERASE = 0x01, BKPT_PROGRAM = 0x02;

// the ROM's function table (RP2040 datasheet 2.8.3, Bootrom Contents: rom_func_table at 0x14, (code, address)
// pairs of uint16 ended by 0): 'RE' and 'RP' each become BKPT #n; BX LR
export function patchedBootrom(file) {
  const rom = Buffer.from(fs.readFileSync(file));
  const table = rom.readUInt16LE(0x14);
  const want = { RE: BKPT_ERASE, RP: BKPT_PROGRAM };
  for (let p = table; rom.readUInt16LE(p) !== 0; p += 4) {
    const code = String.fromCharCode(rom[p], rom[p + 1]);
    if (code in want) {
      const fn = rom.readUInt16LE(p + 2) & ~1;  // Thumb bit off
      rom.writeUInt16LE(0xbe00 | want[code], fn);  // BKPT #n
      rom.writeUInt16LE(0x4770, fn + 2);            // BX LR
      delete want[code];
    }
  }
  if (Object.keys(want).length) throw new Error(`boot ROM ${file} lacks ${Object.keys(want)}`);
  return new Uint32Array(rom.buffer, rom.byteOffset, rom.length / 4);
}

// flash_range_erase(addr, count, block_size, cmd) and flash_range_program(addr, data, count),
// called with r0.. as arguments, addr a flash offset: erase fills 0xff, program ANDs (NOR
// flash). Returns whether `code` was one of the two.
export function flashOp(mcu, flash, code) {
  const r = mcu.core.registers;
  if (code === BKPT_ERASE) {
    flash.fill(0xff, r[0], r[0] + r[1]);
  } else if (code === BKPT_PROGRAM) {
    const [addr, data, count] = [r[0], r[1], r[2]];
    for (let i = 0; i < count; i++) flash[addr + i] &= mcu.readUint8(data + i);
  } else {
    return false;
  }
  return true;
}
