#!/bin/sh
# -DWDR_SIGNING_KEY checks (wdr_boot_key.cmake): the development key is flagged as such, a
# product key is not, and a key of another curve, a private key, or no file stops the configure
# with a message naming the file. usage: boot_key_check.sh SOURCE_DIR SCRATCH_DIR
set -u
src=$1 dir=$2
mkdir -p "$dir"
fail=0
gen() { cmake -DKEY="$1" -DOUT="$dir/key.h" -DBIN="$dir" -P "$src/tests/firmware/boot_key_check.cmake" 2>&1; }
expect() { # expect NAME EXIT REGEX OUTPUT RC
    if [ "$5" -ne "$2" ] || ! printf '%s' "$4" | tr -s '\n ' '  ' | grep -q "$3"; then
        echo "FAIL $1: exit $5 (want $2), output:"; printf '%s\n' "$4"; fail=1
    else echo "ok $1"; fi
}
out=$(gen "$src/firmware/boot/keys/dev-signing-key.NOT-FOR-PRODUCTION.pub.pem"); rc=$?
expect dev-key 0 "development key" "$out" $rc
grep -q "WDR_BOOT_KEY_IS_DEV 1" "$dir/key.h" || { echo "FAIL dev-key: not flagged"; fail=1; }
openssl genpkey -algorithm EC -pkeyopt ec_paramgen_curve:P-256 -out "$dir/product.pem" 2>/dev/null
openssl pkey -in "$dir/product.pem" -pubout -out "$dir/product.pub.pem"
out=$(gen "$dir/product.pub.pem"); rc=$?
expect product-key 0 "Signing key: $dir/product.pub.pem" "$out" $rc
grep -q "WDR_BOOT_KEY_IS_DEV 0" "$dir/key.h" || { echo "FAIL product-key: flagged as dev"; fail=1; }
openssl genpkey -algorithm EC -pkeyopt ec_paramgen_curve:secp256k1 2>/dev/null | openssl pkey -pubout -out "$dir/k1.pub.pem"
out=$(gen "$dir/k1.pub.pem"); rc=$?
expect other-curve 1 "k1.pub.pem: not an ECDSA P-256 public key" "$out" $rc
out=$(gen "$dir/product.pem"); rc=$?
expect private-key 1 "product.pem: not a PEM public key" "$out" $rc
out=$(gen "$dir/none.pem"); rc=$?
expect no-file 1 "none.pem: no such file" "$out" $rc
exit $fail
