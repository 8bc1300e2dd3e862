"""A firmware image (.bin) as a .uf2 file, the form a Raspberry Pi Pico takes by drag and drop.

    python -m desktop.firmware.uf2 firmware.bin firmware.uf2

The rp2 build here runs without picotool (it would be downloaded; ../shared/rp2/SOURCE.md), so
it makes no .uf2; the .bin is the image at the start of flash, and UF2 is that image cut into
256-byte payloads, each in a 512-byte block that names its flash address. The constants are the
pico-sdk's (src/common/boot_uf2_headers/include/boot/uf2.h).
"""

import struct
import sys

MAGIC_START0 = 0x0A324655
MAGIC_START1 = 0x9E5D5157
MAGIC_END = 0x0AB16F30
FLAG_FAMILY_ID_PRESENT = 0x00002000
RP2040_FAMILY_ID = 0xE48BFF56
FLASH_START = 0x10000000    # XIP flash, where the RP2040's boot stage 2 and the image live
PAYLOAD = 256               # bytes of image per block: one flash page
BLOCK = 512


def to_uf2(image, address=FLASH_START, family=RP2040_FAMILY_ID):
    """The bytes of a .uf2 holding `image` (bytes) from flash `address` on."""
    count = (len(image) + PAYLOAD - 1) // PAYLOAD
    out = bytearray()
    for n in range(count):
        data = image[n * PAYLOAD:(n + 1) * PAYLOAD]
        head = struct.pack("<8I", MAGIC_START0, MAGIC_START1, FLAG_FAMILY_ID_PRESENT, address + n * PAYLOAD,
                           PAYLOAD, n, count, family)
        out += head + data + bytes(BLOCK - len(head) - len(data) - 4) + struct.pack("<I", MAGIC_END)
    return bytes(out)


def from_uf2(data):
    """(first address, image bytes) of a .uf2 as to_uf2 writes it (contiguous blocks); ValueError if not."""
    if len(data) % BLOCK:
        raise ValueError("not a UF2 file: %d bytes is not a whole number of 512-byte blocks" % len(data))
    image, first = bytearray(), None
    for n in range(len(data) // BLOCK):
        block = data[n * BLOCK:(n + 1) * BLOCK]
        m0, m1, _flags, addr, size, no, _count, _family = struct.unpack_from("<8I", block)
        if (m0, m1, struct.unpack_from("<I", block, BLOCK - 4)[0]) != (MAGIC_START0, MAGIC_START1, MAGIC_END):
            raise ValueError("not a UF2 file: block %d has no UF2 magic numbers" % n)
        first = addr if first is None else first
        if no != n or addr != first + len(image):
            raise ValueError("UF2 block %d is out of order (address 0x%x)" % (n, addr))
        image += block[32:32 + size]
    return first, bytes(image)


def main(argv=None):
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 2:
        print("usage: python -m desktop.firmware.uf2 FIRMWARE.bin OUT.uf2", file=sys.stderr)
        return 2
    try:
        with open(args[0], "rb") as fh:
            image = fh.read()
        with open(args[1], "wb") as fh:
            fh.write(to_uf2(image))
    except OSError as e:
        print("uf2: %s" % e, file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
