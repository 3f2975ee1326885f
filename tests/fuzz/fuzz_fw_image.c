/* Target fw_image: the host's check of a firmware image file (host/lib/fw_verify.c, what
 * `wdrctl fw info` and `fw upload` run on any file a user names), with no key and with the
 * development key. Invariants: an accepted image is exactly what the firmware's codec reads
 * (header parses, length = header + image_size + trailer), its hash holds, and with the key its
 * key hash and signature hold; every refusal's message starts with the file's name. */
#include "fw_sign.h"
#include "wdr_err.h"
#include <stdlib.h>
#include <string.h>

static void check_once(const uint8_t *data, size_t size, const wdr_fw_key *key)
{
    wdr_fw_image_report r;
    char err[512] = "";
    int rc = wdr_fw_image_check("fuzz.img", data, size, key, &r, err, sizeof err);
    if (rc != WDR_OK) {
        if (strncmp(err, "fuzz.img: ", 10) != 0)
            abort(); /* a refusal that does not name the file */
        return;
    }
    wdr_image_header h;
    if (!r.hash_ok || (key && !(r.key_matches && r.signature_ok)) ||
        wdr_image_header_parse(data, (uint32_t)size, &h) != WDR_OK || wdr_image_total_size(&h) != size)
        abort();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static wdr_fw_key dev;
    static int loaded;
    char err[256];
    if (!loaded && wdr_fw_key_load_dev(&dev, err, sizeof err) != WDR_OK)
        abort();
    loaded = 1;
    check_once(data, size, NULL);
    check_once(data, size, &dev);
    return 0;
}
