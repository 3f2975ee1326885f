/* wdr_image_verify: a good image passes, and each way an image can be wrong is refused with its
 * own code (SPEC.md, "Verification order"); the two crypto primitives against known answers.
 * Images are signed here with OpenSSL (boot_test_util.c), never with the host tool. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "boot_test_util.h"
#include "wdr_boot_crypto.h"
#include "wdr_err.h"
#include <string.h>

#define APP_BYTES 100000u /* ~100 KB, as a real application */

static bt_flash fl;
static bt_key dev, other;
static uint8_t img[160 * 1024];

static int verify_with(uint32_t floor, const wdr_boot_policy *pol)
{
    wdr_image_header h;
    wdr_image_trailer t;
    return wdr_image_verify(&fl.f, fl.l.slot_addr[0], fl.l.image_capacity, pol, floor, &h, &t);
}

static int verify_image(const uint8_t *p, size_t len, uint32_t floor)
{
    bt_flash_init(&fl, 4096, 70);
    bt_flash_image(&fl, 0, p, len);
    wdr_boot_policy pol = bt_policy(&dev);
    return verify_with(floor, &pol);
}

static size_t build(const bt_image_spec *s, const bt_key *signer, const bt_key *hash_key)
{
    return bt_image_build(img, sizeof img, s, signer, hash_key);
}

static void good_image_verifies(void **state)
{
    (void)state;
    bt_image_spec s = bt_spec(2, 7, APP_BYTES);
    size_t n = build(&s, &dev, NULL);
    assert_int_equal(verify_image(img, n, 7), WDR_OK);
    wdr_image_header h;
    wdr_image_trailer t;
    wdr_boot_policy pol = bt_policy(&dev);
    assert_int_equal(wdr_image_verify(&fl.f, fl.l.slot_addr[0], fl.l.image_capacity, &pol, 0, &h, &t), WDR_OK);
    assert_int_equal(h.version.major, 2);
    assert_int_equal(h.security_counter, 7);
    assert_int_equal(h.image_size, APP_BYTES);
    assert_string_equal(h.board, BT_BOARD);
}

static void flipped_bytes_are_hash_errors(void **state)
{
    (void)state;
    bt_image_spec s = bt_spec(1, 1, APP_BYTES);
    size_t n = build(&s, &dev, NULL);
    size_t at[] = {WDR_IMAGE_HEADER_SIZE, WDR_IMAGE_HEADER_SIZE + APP_BYTES / 2, WDR_IMAGE_HEADER_SIZE + APP_BYTES - 1,
                   20 /* build number: in the header, covered too */};
    for (size_t i = 0; i < sizeof at / sizeof at[0]; i++) {
        build(&s, &dev, NULL);
        img[at[i]] ^= 0x10;
        assert_int_equal(verify_image(img, n, 0), WDR_E_HASH);
    }
}

static void another_key_is_a_key_error(void **state)
{
    (void)state;
    bt_image_spec s = bt_spec(1, 1, 4096);
    size_t n = build(&s, &other, NULL);
    assert_int_equal(verify_image(img, n, 0), WDR_E_KEY);
}

static void bad_signature_with_the_right_key_hash(void **state)
{
    (void)state;
    bt_image_spec s = bt_spec(1, 1, 4096);
    size_t n = build(&s, &other, &dev); /* claims the dev key, signed by another */
    assert_int_equal(verify_image(img, n, 0), WDR_E_SIGNATURE);
    build(&s, &dev, NULL);
    img[n - 1] ^= 1; /* last byte of s */
    assert_int_equal(verify_image(img, n, 0), WDR_E_SIGNATURE);
    memset(img + n - WDR_P256_SIG_SIZE, 0, WDR_P256_SIG_SIZE); /* r = s = 0: out of range */
    assert_int_equal(verify_image(img, n, 0), WDR_E_SIGNATURE);
    /* The hash-only build (measured, never shipped) does not look at the signature. */
    wdr_boot_policy pol = bt_policy(&dev);
    pol.check_signature = false;
    assert_int_equal(verify_with(0, &pol), WDR_OK);
}

static void other_board_is_refused(void **state)
{
    (void)state;
    bt_image_spec s = bt_spec(1, 1, 4096);
    s.board = "mps2-an500";
    size_t n = build(&s, &dev, NULL);
    assert_int_equal(verify_image(img, n, 0), WDR_E_BOARD);
    s.board = "sim-vga2"; /* a prefix of the name is not the name */
    n = build(&s, &dev, NULL);
    assert_int_equal(verify_image(img, n, 0), WDR_E_BOARD);
}

static void counter_below_floor_is_a_downgrade(void **state)
{
    (void)state;
    bt_image_spec s = bt_spec(1, 4, 4096);
    size_t n = build(&s, &dev, NULL);
    assert_int_equal(verify_image(img, n, 4), WDR_OK);
    assert_int_equal(verify_image(img, n, 5), WDR_E_DOWNGRADE);
}

static void truncated_and_oversize_images(void **state)
{
    (void)state;
    bt_image_spec s = bt_spec(1, 1, APP_BYTES);
    size_t n = build(&s, &dev, NULL);
    /* ECDSA signs with a fresh nonce: one signature in 256 ends in 0xFF, the erased value, and
     * then the cut image below is the whole image. Sign again until the last byte differs. */
    for (int tries = 0; img[n - 1] == 0xFF && tries < 16; tries++)
        n = build(&s, &dev, NULL);
    assert_int_not_equal(img[n - 1], 0xFF);
    assert_int_equal(verify_image(img, n - WDR_IMAGE_TRAILER_SIZE, 0), WDR_E_INVAL); /* no trailer */
    assert_int_equal(verify_image(img, n / 2, 0), WDR_E_INVAL);
    assert_int_equal(verify_image(img, n - 1, 0), WDR_E_SIGNATURE); /* the last byte erased */
    bt_flash_init(&fl, 4096, 70);
    s = bt_spec(1, 1, fl.l.image_capacity); /* header + trailer no longer fit */
    wdr_image_header h = {.image_size = s.app_size, .load_addr = BT_LOAD_LO, .security_counter = 1};
    strcpy(h.board, BT_BOARD);
    wdr_image_header_pack(&h, img);
    assert_int_equal(verify_image(img, WDR_IMAGE_HEADER_SIZE, 0), WDR_E_TOO_LARGE);
}

static void load_range_is_checked(void **state)
{
    (void)state;
    uint32_t bad[] = {BT_LOAD_LO - 16, BT_LOAD_HI - 4096 + 16, 0xFFFFFFF0u, 0};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        bt_image_spec s = bt_spec(1, 1, 4096);
        s.load_addr = bad[i];
        size_t n = build(&s, &dev, NULL);
        assert_int_equal(verify_image(img, n, 0), WDR_E_INVAL);
    }
    bt_image_spec s = bt_spec(1, 1, 4096);
    s.load_addr = BT_LOAD_HI - 4096; /* ends exactly at the top */
    size_t n = build(&s, &dev, NULL);
    assert_int_equal(verify_image(img, n, 0), WDR_OK);
}

static void structure_errors(void **state)
{
    (void)state;
    bt_image_spec s = bt_spec(1, 1, 4096);
    size_t n = build(&s, &dev, NULL);
    img[6] = 2; /* format major */
    assert_int_equal(verify_image(img, n, 0), WDR_E_VERSION);
    build(&s, &dev, NULL);
    img[0] ^= 1;
    assert_int_equal(verify_image(img, n, 0), WDR_E_CORRUPT);
    build(&s, &dev, NULL);
    img[WDR_IMAGE_HEADER_SIZE + 4096 + 6] = 2; /* trailer: signature type */
    assert_int_equal(verify_image(img, n, 0), WDR_E_INVAL);
    bt_flash_init(&fl, 4096, 70);
    wdr_boot_policy pol = bt_policy(&dev);
    assert_int_equal(verify_with(0, &pol), WDR_E_CORRUPT); /* erased: no image */
}

static void crypto_known_answers(void **state)
{
    (void)state;
    static const uint8_t abc[32] = {0xba, 0x78, 0x16, 0xbf, 0x8f, 0x01, 0xcf, 0xea, 0x41, 0x41, 0x40,
                                    0xde, 0x5d, 0xae, 0x22, 0x23, 0xb0, 0x03, 0x61, 0xa3, 0x96, 0x17,
                                    0x7a, 0x9c, 0xb4, 0x10, 0xff, 0x61, 0xf2, 0x00, 0x15, 0xad};
    uint8_t d[32];
    wdr_sha256_of("abc", 3, d);
    assert_memory_equal(d, abc, 32);
    wdr_sha256 h;
    wdr_sha256_begin(&h);
    wdr_sha256_add(&h, "a", 1);
    wdr_sha256_add(&h, "bc", 2);
    wdr_sha256_end(&h, d);
    assert_memory_equal(d, abc, 32);
    /* A key that is no point of the curve is refused as such. */
    uint8_t bad_key[WDR_P256_PUBKEY_SIZE], sig[WDR_P256_SIG_SIZE] = {1};
    memcpy(bad_key, dev.pub, sizeof bad_key);
    bad_key[64] ^= 1;
    assert_int_equal(wdr_p256_verify(bad_key, d, sig), WDR_E_INVAL);
    assert_int_equal(wdr_p256_verify(dev.pub, d, sig), WDR_E_SIGNATURE);
    assert_int_equal(wdr_boot_key_is_dev(), 1); /* the default build embeds the dev key */
    assert_memory_equal(wdr_boot_key(), dev.pub, WDR_P256_PUBKEY_SIZE);
}

int main(void)
{
    bt_key_dev(&dev);
    bt_key_generate(&other);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(good_image_verifies),
        cmocka_unit_test(flipped_bytes_are_hash_errors),
        cmocka_unit_test(another_key_is_a_key_error),
        cmocka_unit_test(bad_signature_with_the_right_key_hash),
        cmocka_unit_test(other_board_is_refused),
        cmocka_unit_test(counter_below_floor_is_a_downgrade),
        cmocka_unit_test(truncated_and_oversize_images),
        cmocka_unit_test(load_range_is_checked),
        cmocka_unit_test(structure_errors),
        cmocka_unit_test(crypto_known_answers),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
