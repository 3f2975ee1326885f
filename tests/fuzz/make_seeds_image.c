/* Seeds of target image (fuzz_image.h): image flashes a board really has, built through the
 * boot library with images signed by the development key (NOT FOR PRODUCTION). */
#include "boot_test_util.h"
#include "fuzz_image.h"
#include "make_seeds_image.h"
#include "wdr_err.h"
#include <stdlib.h>
#include <string.h>

static bt_flash fl;
static bt_key dev;
static wdr_boot_policy pol;
static uint8_t v1[4096], v2[4096], seed[2 + FZI_FLASH];
static size_t v1_len, v2_len;

static void must(int rc)
{
    if (rc != WDR_OK)
        abort();
}

static void boot(int times)
{
    wdr_boot_decision d;
    for (int i = 0; i < times; i++)
        must(wdr_boot_decide(&fl.f, &fl.l, &pol, &d));
}

static void emit(image_seed_put put, const char *name, uint8_t flags, uint8_t cut)
{
    size_t n = FZI_FLASH;
    while (n && fl.bytes[n - 1] == 0xFF)
        n--; /* the harness erases what the input leaves out */
    seed[0] = flags;
    seed[1] = cut;
    memcpy(seed + 2, fl.bytes, n);
    put("image", name, seed, n + 2);
}

static void factory(void)
{
    bt_flash_init(&fl, FZI_BLOCK, FZI_BLOCKS);
    bt_flash_image(&fl, 0, v1, v1_len);
}

void make_image_seeds(image_seed_put put)
{
    bt_key_dev(&dev);
    pol = bt_policy(&dev);
    bt_image_spec s = bt_spec(1, 1, 1024);
    v1_len = bt_image_build(v1, sizeof v1, &s, &dev, NULL);
    s = bt_spec(2, 2, 1600);
    v2_len = bt_image_build(v2, sizeof v2, &s, &dev, NULL);

    bt_flash_init(&fl, FZI_BLOCK, FZI_BLOCKS);
    emit(put, "erased", 0, 0);
    factory();
    emit(put, "factory", FZI_SIGNATURE, 0);
    emit(put, "factory_fixed_confirm", FZI_FIX_HASHES | FZI_CONFIRM, 0);
    boot(1);
    must(bt_upload(&fl, 1, v2, v2_len, 500, &pol));
    emit(put, "pending", 0, 0);
    emit(put, "pending_cut_torn", 2u << FZI_TEAR_SHIFT, 1);
    boot(2);
    emit(put, "testing_2", FZI_CONFIRM, 0);
    emit(put, "testing_2_revert", FZI_REVERT | FZI_FIX_HASHES, 0);
    boot(2);
    emit(put, "rejected_unconfirmed", 0, 0);
    factory();
    boot(1);
    must(bt_upload(&fl, 1, v2, v2_len, 500, &pol));
    boot(1);
    must(wdr_boot_confirm(&fl.f, &fl.l, &pol, 1));
    emit(put, "confirmed_floor_2", FZI_SIGNATURE | FZI_REVERT, 0);
    boot(1);
    emit(put, "v1_rejected_downgrade", 0, 0);
    factory();
    boot(1);
    wdr_boot_upload u;
    must(wdr_boot_upload_begin(&fl.f, &fl.l, &u, 1, (uint32_t)v2_len, 0));
    must(wdr_boot_upload_chunk(&fl.f, &fl.l, &u, 0, v2, 700));
    emit(put, "upload_incomplete", 0, 0);
}
