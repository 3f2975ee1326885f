#!/bin/sh
# The mps2-an500's factory image: what a blank board's flash holds after production, as one
# Intel hex that GDB (`load`), OpenOCD or pyOCD program in one go:
#   the bootloader at the reset vector (its .hex), and the whole image flash at 0x60600000
#   (2 MiB, SPEC.md "Image flash and boot"): the floor log erased, slot A (from block 2) the
#   signed v1 then erased to its end with its state block, slot B erased.
# usage: make_factory.sh WDRCTL KEY.pem BOOT_HEX APP_BIN OUT_DIR
# Writes OUT_DIR/wdr_mps2_v1.img (1.0.0, security counter 1, signed with KEY by wdrctl fw sign)
# and OUT_DIR/wdr_mps2_factory.hex.
set -eu
wdrctl=$1 key=$2 boot_hex=$3 app_bin=$4 out=$5
image_flash_base=0x60600000
image_flash_bytes=2097152
slot_a_offset=8192 # blocks 0-1 are the floor log, 4 KiB blocks
mkdir -p "$out"
"$wdrctl" fw sign -k "$key" -o "$out/wdr_mps2_v1.img" --version 1.0.0 --security-counter 1 \
    --board mps2-an500 --load-addr 0x00020000 "$app_bin" >/dev/null
tr '\000' '\377' </dev/zero | head -c $image_flash_bytes >"$out/image_flash.bin"
dd if="$out/wdr_mps2_v1.img" of="$out/image_flash.bin" bs=$slot_a_offset seek=1 conv=notrunc status=none
objcopy -I binary -O ihex --change-addresses=$image_flash_base "$out/image_flash.bin" "$out/image_flash.hex"
# Intel hex records carry their own extended addresses: the parts concatenate, with one end record.
{ grep -v '^:00000001FF' "$boot_hex"; cat "$out/image_flash.hex"; } >"$out/wdr_mps2_factory.hex"
rm -f "$out/image_flash.bin" "$out/image_flash.hex"
