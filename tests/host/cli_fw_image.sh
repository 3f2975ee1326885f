#!/bin/sh
# usage: cli_fw_image.sh WDRCTL KEYS_DIR WORKDIR
# wdrctl fw sign / fw info as a user runs them, with keys made by `openssl genpkey`: round trip,
# the development key flagged, the signature and key hash checked by the openssl program itself
# (raw r||s made DER with asn1parse, pkeyutl -verify), a flipped byte, another key, malformed
# files and bad options refused with the file, field and value named; fw upload refuses a bad
# file before it looks for a board.
set -u
ctl=$1; keys=$2; d=$3
dev=$keys/dev-signing-key.NOT-FOR-PRODUCTION.pem
rm -rf "$d" && mkdir -p "$d" && cd "$d" || exit 1

fail() { echo "FAIL: $*"; exit 1; }
# expect EXIT REGEX CMD...: the exit code and a line of the output
expect() {
    want=$1; regex=$2; shift 2
    out=$("$@" 2>&1); rc=$?
    printf '%s\n' "$out"
    [ "$rc" -eq "$want" ] || fail "exit $rc, expected $want: $*"
    printf '%s\n' "$out" | grep -q -- "$regex" || fail "output lacks /$regex/: $*"
}
hex() { od -An -tx1 -v -j "$2" -N "$3" "$1" | tr -d ' \n'; }
# put FILE OFFSET OCTAL-ESCAPES: overwrite bytes in place
put() { printf "$3" | dd of="$1" bs=1 seek="$2" conv=notrunc 2>/dev/null; }

openssl genpkey -algorithm EC -pkeyopt ec_paramgen_curve:P-256 -out product.pem 2>/dev/null || fail "genpkey"
openssl pkey -in product.pem -pubout -out product.pub.pem || fail "pkey -pubout"
openssl genpkey -algorithm EC -pkeyopt ec_paramgen_curve:P-384 -out p384.pem 2>/dev/null || fail "genpkey P-384"
head -c 3000 /dev/urandom > app.bin # padded to 3008: the trailer starts at 3072

# ---- round trip ----
expect 0 "development key: not for production" "$ctl" fw sign --key "$dev" app.bin -o dev.img --version 1.0.0+1 \
    --board sim-vga
expect 0 "signature:         holds with the built-in development key" "$ctl" fw info dev.img
expect 0 "signature:         holds with product.pem" "$ctl" fw sign --key product.pem app.bin -o product.img \
    --version 2.3.4+56 --security-counter 9 --board mps2-an500 --load-addr 0x00400000
expect 0 "security counter:  9" "$ctl" fw info product.img --key product.pub.pem
printf '%s\n' "$out" | grep -q "development key" && fail "a product key's image is called a development one"
expect 0 '"version":	"2.3.4+56"' "$ctl" fw info product.img --key product.pub.pem --json
printf '%s\n' "$out" | grep -q '"signature":	"holds"' || fail "JSON lacks the signature verdict"
expect 0 "signature:         not checked" "$ctl" fw info product.img
[ "$(wc -c < product.img)" -eq 3208 ] || fail "image is not 64 + 3008 + 136 bytes"

# ---- the openssl program agrees: SHA-256, key hash, signature ----
head -c 3072 product.img | openssl dgst -sha256 -binary > digest.bin
[ "$(hex digest.bin 0 32)" = "$(hex product.img 3080 32)" ] || fail "trailer SHA-256 differs from openssl dgst's"
openssl pkey -pubin -in product.pub.pem -outform DER | tail -c 65 | openssl dgst -sha256 -binary > keyhash.bin
[ "$(hex keyhash.bin 0 32)" = "$(hex product.img 3112 32)" ] || fail "key hash is not SHA-256 of the 65-byte point"
printf 'asn1=SEQUENCE:sig\n[sig]\nr=INTEGER:0x%s\ns=INTEGER:0x%s\n' "$(hex product.img 3144 32)" \
    "$(hex product.img 3176 32)" > sig.cnf
openssl asn1parse -genconf sig.cnf -out sig.der -noout > /dev/null || fail "asn1parse"
expect 0 "Signature Verified Successfully" openssl pkeyutl -verify -pubin -inkey product.pub.pem -in digest.bin \
    -sigfile sig.der

# ---- refusals: the file, the field, the value ----
cp product.img flipped.img && put flipped.img 100 '\377'
expect 65 "flipped.img: trailer field sha256: .*the image is damaged" "$ctl" fw info flipped.img --key product.pub.pem
expect 65 "dev.img: trailer field key_hash: .*signed by another key than product.pub.pem" "$ctl" fw info dev.img \
    --key product.pub.pem
cp product.img size17.img && put size17.img 8 '\021\000\000\000'
expect 65 "size17.img: header field image_size: 17 is not a multiple of 16" "$ctl" fw info size17.img
head -c 10 product.img > short.img
expect 65 "short.img: 10 bytes, shorter than the 64-byte image header" "$ctl" fw info short.img
expect 65 "app.bin: header field magic: 0x[0-9a-f]*, not 0x474d4957 (WIMG): not a signed image" "$ctl" fw info app.bin
head -c 3207 product.img > cut.img
expect 65 "cut.img: 3207 bytes, but header field image_size says 3208 .*truncated" "$ctl" fw info cut.img
cp product.img board.img && put board.img 45 '\001'
expect 65 "board.img: header field board: byte 13 after the name's NUL is 0x01" "$ctl" fw info board.img
expect 65 "p384.pem: not an ECDSA P-256 key" "$ctl" fw sign --key p384.pem app.bin -o x.img
expect 65 "product.pub.pem: a public key cannot sign" "$ctl" fw sign --key product.pub.pem app.bin -o x.img
expect 64 "fw sign: option --version: '1.2' is not MAJOR.MINOR.PATCH" "$ctl" fw sign --key product.pem app.bin \
    -o x.img --version 1.2
expect 64 "option --security-counter: '-1'" "$ctl" fw sign --key product.pem app.bin -o x.img --security-counter -1
expect 64 "option --load-addr: '4294967296' is out of range" "$ctl" fw sign --key product.pem app.bin -o x.img \
    --load-addr 4294967296
expect 65 "header field board: 'a b' is not 1..15 printable" "$ctl" fw sign --key product.pem app.bin -o x.img \
    --board 'a b'
expect 65 "header field load_addr: 0x00000002 is not a multiple of 4" "$ctl" fw sign --key product.pem app.bin \
    -o x.img --load-addr 2
expect 66 "cannot read missing.bin" "$ctl" fw sign --key product.pem missing.bin -o x.img
expect 66 "missing.pem: cannot read the key file" "$ctl" fw sign --key missing.pem app.bin -o x.img
# before any board: the file's fault, not an absent board (69)
expect 65 "size17.img: header field image_size: 17" "$ctl" fw upload size17.img --device sim:/nonexistent/b.sock
echo "ok: fw sign and fw info"
