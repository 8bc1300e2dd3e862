"""desktop/firmware/uf2.py: the .uf2 a real Pico takes, from the rp2 build's firmware.bin."""

import os
import re

import pytest

from desktop.firmware import uf2
from desktop.firmware.interpreters import BUILD
from tests.interpreters import need


def test_the_constants_are_the_pico_sdk_s():
    header = os.path.join(BUILD, "src", "micropython-1.28.0-rp2", "lib", "pico-sdk", "src", "common",
                          "boot_uf2_headers", "include", "boot", "uf2.h")
    if not os.path.exists(header):
        pytest.skip("the rp2 source tree is not unpacked (make interpreters)")
    with open(header) as fh:
        defined = dict((name, int(value, 16)) for name, value in re.findall(r"#define (\w+)\s+(0x[0-9a-fA-F]+)", fh.read()))
    for name in ("MAGIC_START0", "MAGIC_START1", "MAGIC_END", "FLAG_FAMILY_ID_PRESENT"):
        assert getattr(uf2, name) == defined["UF2_" + name], name
    assert uf2.RP2040_FAMILY_ID == defined["RP2040_FAMILY_ID"]


def test_an_image_cut_into_blocks_reads_back_whole_at_its_address():
    image = bytes(range(256)) * 3 + b"tail"      # a last payload shorter than a page: padded, not lost
    data = uf2.to_uf2(image)
    assert len(data) == 4 * uf2.BLOCK
    address, back = uf2.from_uf2(data)
    assert address == uf2.FLASH_START and back[:len(image)] == image and back[len(image):] == bytes(256 - 4)


def test_a_file_that_is_not_uf2_is_refused_in_one_line():
    with pytest.raises(ValueError, match="not a UF2 file"):
        uf2.from_uf2(bytes(512))
    with pytest.raises(ValueError, match="whole number"):
        uf2.from_uf2(bytes(100))


def test_the_frozen_build_s_uf2_is_its_firmware_bin():
    firmware = need("rp2-pico-frozen")
    with open(firmware, "rb") as fh:
        image = fh.read()
    with open(os.path.join(os.path.dirname(firmware), "firmware.uf2"), "rb") as fh:
        address, back = uf2.from_uf2(fh.read())
    assert address == 0x10000000 and back.rstrip(b"\0") == image.rstrip(b"\0")
