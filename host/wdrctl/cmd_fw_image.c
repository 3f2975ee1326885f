/* wdrctl fw sign, wdrctl fw info: signed firmware images as files (host/lib/fw_sign.h; the
 * format in firmware/SPEC.md, "Firmware image format"). No board involved. */
#include "file_io.h"
#include "fw_sign.h"
#include "wdr_err.h"
#include "wdr_fw_config.h"
#include "wdrctl.h"
#include "wdrctl_fw.h"
#include <cJSON.h>
#include <errno.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct fw_image_opts {
    const char *key, *out, *version, *board;
    uint64_t counter, load_addr;
    int ram_load, json;
} fw_image_opts;

#define O(f) offsetof(fw_image_opts, f)
static const cli_choice on_off[] = {{"on", 1}, {"off", 0}, {NULL, 0}};
static const cli_option sign_rows[] = {
    {"key", 'k', CLI_STRING, O(key), "KEY.pem", "private P-256 key (openssl genpkey, see firmware/boot/keys/README.md)",
     .flags = CLI_REQUIRED},
    {"output", 'o', CLI_STRING, O(out), "APP.img", "the signed image", .flags = CLI_REQUIRED},
    {"version", 0, CLI_STRING, O(version), "X.Y.Z[+BUILD]", "image version (default: this tree's firmware version)"},
    {"security-counter", 0, CLI_U64, O(counter), "N",
     "anti-rollback counter: a board never boots an image below its floor (default 0)", .min = 0, .max = 4294967295.0},
    {"board", 0, CLI_STRING, O(board), "NAME", "the board the image is for (default: the build's -DWDR_BOARD)"},
    {"load-addr", 0, CLI_U64, O(load_addr), "ADDR",
     "where the application's vector table runs, e.g. 0x00400000 (default 0)", .min = 0, .max = 4294967295.0},
    {"ram-load", 0, CLI_CHOICE, O(ram_load), NULL,
     "the RAM-load flag: the bootloader copies the application to ADDR (default on: ours copies every image)",
     .choices = on_off, .what = "RAM-load setting"},
    {"json", 0, CLI_FLAG, O(json), NULL, "print what was written as JSON"},
    {0}};
static const cli_option info_rows[] = {
    {"key", 'k', CLI_STRING, O(key), "PUB.pem", "check the signature with this key (public or private PEM)"},
    {"json", 0, CLI_FLAG, O(json), NULL, "print JSON"},
    {0}};
#undef O

const cli_command wdrctl_cmd_fw_sign = {
    "fw sign", "APP.bin", 1, 1, "sign an application into a firmware image",
    "Pads the application to 16 bytes, writes the 64-byte header (version, security counter, board, load "
    "address, flags), the SHA-256 of header and application, the key's hash and the ECDSA P-256 signature. "
    "An image signed with the tree's development key is flagged: not for production.",
    sign_rows, cmd_fw_sign};
const cli_command wdrctl_cmd_fw_info = {
    "fw info", "APP.img", 1, 1, "check a firmware image: fields, SHA-256, signature",
    "Every header and trailer field is checked and named when it is out of range. The signature is checked "
    "with --key, or with the built-in development key when the image names it. Exit 65 when anything fails.",
    info_rows, cmd_fw_info};

/* ---- Shared with the board commands (wdrctl_fw.h) ------------------------------------------------ */

int wdrctl_fw_read_image(const char *path, uint8_t **buf, size_t *len)
{
    int rc = wdr_read_file(path, buf, len);
    if (rc != WDR_OK)
        return wdrctl_fail(rc == WDR_E_IO ? EX_NOINPUT : EX_OSERR, "cannot read %s: %s", path,
                           rc == WDR_E_IO ? strerror(errno) : "out of memory");
    return EX_OK;
}

int wdrctl_fw_check_exit(int rc)
{
    switch (rc) {
    case WDR_OK: return EX_OK;
    case WDR_E_NOMEM: return EX_OSERR;
    case WDR_E_IO: return EX_NOINPUT;
    default: return EX_DATAERR;
    }
}

/* ---- fw sign ----------------------------------------------------------------------------------------- */

/* The board named by the build's board file (.../boards/NAME/board.json). */
static const char *build_board(char *out, size_t cap)
{
    char dir[1024];
    snprintf(dir, sizeof dir, "%s", WDR_DEFAULT_BOARD);
    char *slash = strrchr(dir, '/');
    if (slash)
        *slash = 0; /* the folder of board.json */
    slash = strrchr(dir, '/');
    const char *name = slash ? slash + 1 : dir;
    size_t n = strlen(name) < cap ? strlen(name) : cap - 1;
    memcpy(out, name, n);
    out[n] = 0;
    return out;
}

static int sign_params(const fw_image_opts *o, wdr_fw_sign_params *p, char *board, size_t cap)
{
    *p = (wdr_fw_sign_params){.version = {WDR_FW_VERSION_MAJOR, WDR_FW_VERSION_MINOR, 0, 0},
                              .security_counter = (uint32_t)o->counter,
                              .load_addr = (uint32_t)o->load_addr,
                              .board = o->board ? o->board : build_board(board, cap),
                              .ram_load = o->ram_load};
    if (o->version && wdr_fw_version_parse(o->version, &p->version) != WDR_OK)
        return wdrctl_fail(EX_USAGE, "fw sign: option --version: '%s' is not MAJOR.MINOR.PATCH[+BUILD] "
                           "(0..255.0..255.0..65535, build 0..4294967295)", o->version);
    return EX_OK;
}

static int write_file(const char *path, const uint8_t *buf, size_t len)
{
    FILE *f = fopen(path, "wb");
    int ok = f && fwrite(buf, 1, len, f) == len;
    if (f && fclose(f) != 0)
        ok = 0;
    return ok ? EX_OK : wdrctl_fail(EX_CANTCREAT, "cannot write %s: %s", path, strerror(errno));
}

static int sign_file(const fw_image_opts *o, const char *app_path, const wdr_fw_sign_params *p, const wdr_fw_key *key)
{
    uint8_t *app = NULL, *img = NULL;
    size_t app_len = 0, img_len = 0;
    char err[512];
    int rc = wdrctl_fw_read_image(app_path, &app, &app_len);
    if (rc != EX_OK)
        return rc;
    int r = wdr_fw_sign(app_path, app, app_len, p, key, &img, &img_len, err, sizeof err);
    free(app);
    if (r != WDR_OK)
        return wdrctl_fail(r == WDR_E_NOMEM ? EX_OSERR : r == WDR_E_SIGNATURE ? EX_SOFTWARE : EX_DATAERR, "%s", err);
    rc = write_file(o->out, img, img_len);
    if (rc == EX_OK)
        rc = wdrctl_fw_print_image(o->out, img, img_len, key, o->json);
    free(img);
    return rc;
}

int cmd_fw_sign(int argc, char **argv)
{
    fw_image_opts o = {.ram_load = 1};
    int n_args = 0;
    int rc = wdrctl_parse(&wdrctl_cmd_fw_sign, argc, argv, &o, &n_args);
    wdr_fw_sign_params p;
    char board[64], err[512];
    if (rc != EX_OK || (rc = sign_params(&o, &p, board, sizeof board)) != EX_OK)
        return rc;
    wdr_fw_key key;
    int r = wdr_fw_key_load(o.key, 1, &key, err, sizeof err);
    if (r != WDR_OK)
        return wdrctl_fail(r == WDR_E_IO ? EX_NOINPUT : EX_DATAERR, "%s", err);
    rc = sign_file(&o, argv[1], &p, &key);
    wdr_fw_key_free(&key);
    return rc;
}

/* ---- fw info ------------------------------------------------------------------------------------------ */

static const char *signature_word(const wdr_fw_image_report *r)
{
    if (!r->key_checked)
        return "not checked (give --key PUB.pem)";
    if (!r->key_matches)
        return "signed by another key";
    return r->signature_ok ? "holds" : "does not verify";
}

static void flags_text(uint32_t flags, char *out, size_t cap)
{
    snprintf(out, cap, "0x%x (%s%s)", flags, flags & WDR_IMAGE_F_RAM_LOAD ? "RAM load" : "in place",
             flags & WDR_IMAGE_F_DEV_KEY ? ", development key" : "");
}

static void print_text(const char *path, const wdr_fw_image_report *r, const wdr_fw_key *key)
{
    char ver[48], flags[64], sha[65], kh[65];
    const wdr_image_header *h = &r->hdr;
    wdr_fw_version_format(&h->version, ver, sizeof ver);
    flags_text(h->flags, flags, sizeof flags);
    wdr_fw_hex(r->trl.sha256, WDR_SHA256_SIZE, sha);
    wdr_fw_hex(r->trl.key_hash, WDR_SHA256_SIZE, kh);
    printf("file:              %s\nversion:           %s\nboard:             %s\n", path, ver, h->board);
    printf("application:       %u bytes (image %u bytes)\nload address:      0x%08x\n", h->image_size,
           wdr_image_total_size(h), h->load_addr);
    printf("security counter:  %u\nflags:             %s\nsha256:            %s\nkey hash:          %s\n",
           h->security_counter, flags, sha, kh);
    printf("hash:              %s\n", r->hash_ok ? "holds" : "DOES NOT HOLD (damaged)");
    printf("signature:         %s%s%s\n", signature_word(r), !key ? "" : r->key_matches ? " with " : " than ",
           key ? key->name : "");
    if (r->dev_key)
        printf("development key: not for production\n");
}

static void print_json(const char *path, const wdr_fw_image_report *r, const wdr_fw_key *key)
{
    char ver[48], hex[65];
    const wdr_image_header *h = &r->hdr;
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "file", path);
    wdr_fw_version_format(&h->version, ver, sizeof ver);
    cJSON_AddStringToObject(o, "version", ver);
    cJSON_AddNumberToObject(o, "major", h->version.major);
    cJSON_AddNumberToObject(o, "minor", h->version.minor);
    cJSON_AddNumberToObject(o, "patch", h->version.patch);
    cJSON_AddNumberToObject(o, "build", h->version.build);
    cJSON_AddStringToObject(o, "board", h->board);
    cJSON_AddNumberToObject(o, "image_size", h->image_size);
    cJSON_AddNumberToObject(o, "total_size", wdr_image_total_size(h));
    snprintf(hex, sizeof hex, "0x%08x", h->load_addr);
    cJSON_AddStringToObject(o, "load_addr", hex);
    cJSON_AddNumberToObject(o, "security_counter", h->security_counter);
    cJSON_AddNumberToObject(o, "flags", h->flags);
    cJSON_AddBoolToObject(o, "ram_load", (h->flags & WDR_IMAGE_F_RAM_LOAD) != 0);
    cJSON_AddBoolToObject(o, "dev_key", r->dev_key);
    wdr_fw_hex(r->trl.sha256, WDR_SHA256_SIZE, hex);
    cJSON_AddStringToObject(o, "sha256", hex);
    wdr_fw_hex(r->trl.key_hash, WDR_SHA256_SIZE, hex);
    cJSON_AddStringToObject(o, "key_hash", hex);
    cJSON_AddBoolToObject(o, "hash_ok", r->hash_ok);
    const char *verdict = !r->key_checked  ? "not checked"
                          : !r->key_matches ? "other key"
                          : r->signature_ok ? "holds"
                                            : "fails";
    cJSON_AddStringToObject(o, "signature", verdict);
    if (key)
        cJSON_AddStringToObject(o, "key", key->name);
    char *text = cJSON_Print(o);
    printf("%s\n", text ? text : "{}");
    free(text);
    cJSON_Delete(o);
}

int wdrctl_fw_print_image(const char *path, const uint8_t *img, size_t len, const wdr_fw_key *key, int json)
{
    wdr_fw_image_report r;
    char err[512];
    int rc = wdr_fw_image_check(path, img, len, key, &r, err, sizeof err);
    int parsed = rc == WDR_OK || rc == WDR_E_HASH || rc == WDR_E_KEY || rc == WDR_E_SIGNATURE;
    if (parsed)
        (json ? print_json : print_text)(path, &r, key);
    return rc == WDR_OK ? EX_OK : wdrctl_fail(wdrctl_fw_check_exit(rc), "%s", err);
}

/* The key to check with: --key, else the development key when the image names it. */
static int info_key(const fw_image_opts *o, const uint8_t *img, size_t len, wdr_fw_key *key, int *have)
{
    char err[512];
    *have = 0;
    if (o->key) {
        int r = wdr_fw_key_load(o->key, 0, key, err, sizeof err);
        if (r != WDR_OK)
            return wdrctl_fail(r == WDR_E_IO ? EX_NOINPUT : EX_DATAERR, "%s", err);
        *have = 1;
        return EX_OK;
    }
    wdr_image_header h;
    wdr_image_trailer t;
    if (len < WDR_IMAGE_HEADER_SIZE || wdr_image_header_parse(img, UINT32_MAX, &h) != WDR_OK ||
        len != wdr_image_total_size(&h) || wdr_image_trailer_parse(img + len - WDR_IMAGE_TRAILER_SIZE, &t) != WDR_OK ||
        wdr_fw_key_load_dev(key, err, sizeof err) != WDR_OK)
        return EX_OK; /* the check itself names what is wrong */
    if (memcmp(t.key_hash, key->hash, WDR_SHA256_SIZE)) {
        wdr_fw_key_free(key);
        return EX_OK;
    }
    *have = 1;
    return EX_OK;
}

int cmd_fw_info(int argc, char **argv)
{
    fw_image_opts o = {0};
    int n_args = 0;
    int rc = wdrctl_parse(&wdrctl_cmd_fw_info, argc, argv, &o, &n_args);
    uint8_t *img = NULL;
    size_t len = 0;
    if (rc != EX_OK || (rc = wdrctl_fw_read_image(argv[1], &img, &len)) != EX_OK)
        return rc;
    wdr_fw_key key;
    int have_key = 0;
    rc = info_key(&o, img, len, &key, &have_key);
    if (rc == EX_OK)
        rc = wdrctl_fw_print_image(argv[1], img, len, have_key ? &key : NULL, o.json);
    if (have_key)
        wdr_fw_key_free(&key);
    free(img);
    return rc;
}
