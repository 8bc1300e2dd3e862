# Random ints from a fixed 32-bit LCG (not `random`), the same on CPython and every board: the
# scripts here that compare two implementations on a board import it from the repository's
# tests/micropython/ (the emulated boards get it as .mpy beside them).


class Rand:
    """Random ints from a 32-bit LCG, the same on every interpreter."""

    def __init__(self, seed):
        self.state = seed

    def bits(self, n):
        """n random bits, 0 <= v < 2**n."""
        v = 0
        k = 0
        while k < n:
            self.state = (1103515245 * self.state + 12345) & 0xFFFFFFFF
            v = (v << 16) | (self.state >> 16)
            k += 16
        return v >> (k - n)

    def signed(self, n):
        """-2**n <= v < 2**n, uniform."""
        return self.bits(n + 1) - (1 << n)
