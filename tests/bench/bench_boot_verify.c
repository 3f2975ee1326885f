/* One full verification of a ~100 KB image by the boot library on the host (wdr_image_verify
 * over the NOR emulator: header, SHA-256 streamed over 256-byte reads, key hash, ECDSA P-256
 * through Debian's libmbedcrypto), with the signature check and hash only. Prints the time per
 * verification; under callgrind, the instructions of each:
 *   valgrind --tool=callgrind --toggle-collect=verify_signed build/tests/bench/bench_boot_verify --once
 *   (and --toggle-collect=verify_hash_only)
 * usage: bench_boot_verify [--quick | --once] */
#include "boot_test_util.h"
#include "wdr_err.h"
#include <stdio.h>
#include <string.h>
#include <time.h>

#define APP_BYTES 100000u

static bt_flash fl;
static bt_key dev;
static uint8_t img[128 * 1024];

static int verify(bool signature)
{
    wdr_boot_policy pol = bt_policy(&dev);
    pol.check_signature = signature;
    wdr_image_header h;
    wdr_image_trailer t;
    return wdr_image_verify(&fl.f, fl.l.slot_addr[0], fl.l.image_capacity, &pol, 0, &h, &t);
}

/* Named so that callgrind can count each alone (--toggle-collect). */
__attribute__((noinline)) static int verify_signed(void) { return verify(true); }
__attribute__((noinline)) static int verify_hash_only(void) { return verify(false); }

static double ms_per(int (*fn)(void), int n)
{
    struct timespec a, b;
    clock_gettime(CLOCK_MONOTONIC, &a);
    for (int i = 0; i < n; i++)
        if (fn() != WDR_OK) {
            fprintf(stderr, "bench_boot_verify: the image does not verify\n");
            return -1;
        }
    clock_gettime(CLOCK_MONOTONIC, &b);
    return ((double)(b.tv_sec - a.tv_sec) * 1e3 + (double)(b.tv_nsec - a.tv_nsec) / 1e6) / n;
}

int main(int argc, char **argv)
{
    bool quick = argc > 1 && !strcmp(argv[1], "--quick"), once = argc > 1 && !strcmp(argv[1], "--once");
    bt_key_dev(&dev);
    bt_image_spec s = bt_spec(1, 1, APP_BYTES);
    size_t n = bt_image_build(img, sizeof img, &s, &dev, NULL);
    bt_flash_init(&fl, 4096, 70);
    bt_flash_image(&fl, 0, img, n);
    if (once)
        return verify_signed() || verify_hash_only();
    int reps = quick ? 3 : 200;
    double sig = ms_per(verify_signed, reps), hash = ms_per(verify_hash_only, reps);
    if (sig < 0 || hash < 0)
        return 1;
    printf("bench_boot_verify: %zu-byte image, %d runs: %.3f ms with the signature check, %.3f ms hash only "
           "(%.0f MB/s SHA-256 over flash reads)\n",
           n, reps, sig, hash, (double)n / (hash * 1e3));
    return 0;
}
