"""The emulated ADS1292's command decoder and register file.

:class:`CommandDecoder` is the part of :class:`~desktop.sim.ads1292.chip.ADS1292`
that reads the bytes a selected chip gets on DIN as the datasheet's commands
[DS §8.5.2 Table 15] (RREG / WREG with their count and data bytes) and keeps
the register file [DS §8.6], as strict as the real chip about timing and fixed
bits: whatever breaks a rule is recorded in `violations`.

It works on the chip's state (`registers`, `rdatac`, `standby`, `tick`,
`strict`, the START pin and command, the frame) and calls back the chip's
`_power_on_reset`, `_begin_conversions` and `_violate`.
"""

from desktop.sim.ads1292.registers import (CONFIG1, CH1SET, CH2SET, DECODE_TICKS, FIXED, ID, N_REGISTERS,
                                           OFFSETCAL, RDATA, RDATAC, RESET, RESET_BUSY_TICKS, RREG, SDATAC,
                                           STANDBY, START, STOP, WAKE_TICKS, WAKEUP, WREG, WRITABLE)


class CommandDecoder:
    """Mixed into ADS1292: opcodes in, state changes and register reads out."""

    def _reset_decoder(self):
        """Forget a command in progress (CS high, reset): the next byte is an opcode."""
        self._cmd = []                 # bytes of a multi-byte command in progress
        self._pending_out = b""        # RREG / RDATA output queued for next bytes
        self._wreg_left = 0            # WREG data bytes still to come
        self._swallow = 0              # data bytes of an ignored WREG, not commands

    def _decoder_idle(self):
        """No command in progress and no RREG / RDATA output queued."""
        return not (self._pending_out or self._cmd or self._wreg_left or self._swallow)

    def _decode(self, b):
        if self._swallow:
            self._swallow -= 1
            return
        if self._wreg_left:
            addr = self._cmd[0] & 0x1F
            self._write_register(addr + len(self._cmd) - 2, b)
            self._cmd.append(b)
            self._wreg_left -= 1
            if not self._wreg_left:
                self._cmd = []
            return
        if self._cmd:                            # count byte of RREG / WREG
            self._count_byte(b)
            return
        if b == 0x00:
            return                               # DIN idle while reading
        if self.tick < self._busy_until:
            self._violate("command 0x%02X %d ticks too early (after power-up/RESET/previous command)"
                          % (b, self._busy_until - self.tick))
            if self.strict:
                return
        if self.standby and b != WAKEUP:
            self._violate("only WAKEUP may follow STANDBY [DS §8.5.2.2]; got 0x%02X" % b)
            return
        if b & 0xE0 in (RREG, WREG):
            self._cmd = [b]
            return
        self._busy_until = self.tick + DECODE_TICKS
        self._command(b)

    def _count_byte(self, b):
        """The second byte of RREG / WREG: count - 1."""
        op = self._cmd[0]
        count = (b & 0x1F) + 1
        addr = op & 0x1F
        if op & 0xE0 == RREG:
            self._cmd = []
            if self.rdatac:
                self._violate("RREG ignored in RDATAC mode: send SDATAC first [DS §8.5.2.7]")
                return
            regs = [self._read_register(a) for a in range(addr, addr + count)]
            self._pending_out = bytes(regs)
        else:
            self._cmd.append(b)
            if self.rdatac:
                self._violate("WREG ignored in RDATAC mode: send SDATAC first [DS §8.5.2.7]")
                self._cmd, self._wreg_left = [], 0
                self._swallow = count            # its data bytes are not commands
                return
            self._wreg_left = count

    def _command(self, b):
        """A one-byte command."""
        if b == WAKEUP:
            if self.standby:
                self.standby = False
                if self._running:
                    self._begin_conversions(delay=WAKE_TICKS)
        elif b == STANDBY:
            self.standby = True
            self.schedule.stop()
        elif b == RESET:
            start_pin = self._start_pin
            self._power_on_reset()
            self._busy_until = self.tick + RESET_BUSY_TICKS
            if start_pin:
                self._begin_conversions(delay=RESET_BUSY_TICKS)
        elif b == START:
            if self._start_pin:
                self._violate("START command with START pin high: hold the pin low [DS §8.5.2.4]")
            self._start_cmd = True
            self._begin_conversions()
        elif b == STOP:
            self._start_cmd = False
            if not self._start_pin:
                self._stop_after_next = self.schedule.next_drdy is not None
        elif b == RDATAC:
            self.rdatac = True
            self._out_ptr = 0
        elif b == SDATAC:
            self.rdatac = False
        elif b == RDATA:
            if self.rdatac:
                self._violate("RDATA in RDATAC mode")
            self._pending_out = self.frame
        elif b == OFFSETCAL:
            pass                                 # offset calibration: offsets are not modelled
        else:
            self._violate("unknown opcode 0x%02X" % b)

    # ------------------------------------------------------- register file
    def _read_register(self, addr):
        if addr >= N_REGISTERS:
            return 0x00
        return self.registers[addr]

    def _write_register(self, addr, value):
        if addr >= N_REGISTERS or addr == ID:
            self._violate("WREG to read-only/unknown address 0x%02X" % addr)
            return
        mask = WRITABLE[addr]
        fixed = FIXED[addr] & ~mask & 0xFF        # bits that "must be" 0 or 1 [DS §8.6.1]
        if value & ~mask & 0xFF != fixed:
            self._violate("register 0x%02X written 0x%02X: its fixed bits must read 0x%02X"
                          % (addr, value, fixed))
        self.registers[addr] = fixed | (value & mask)
        if addr == CONFIG1 and self._running and self.schedule.next_drdy is not None:
            self._begin_conversions()            # writing CONFIG1 resets the digital filter [DS §8.5.1.8]
        if addr == CONFIG1 and value & 0x07 == 0x07:
            self._violate("CONFIG1 DR=111 is 'do not use'")
        if addr in (CH1SET, CH2SET) and (value >> 4) & 0x07 == 0x07:
            self._violate("CH%dSET gain code 111 is not defined" % (addr - 3))
