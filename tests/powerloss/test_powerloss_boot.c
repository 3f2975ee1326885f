/* Power-loss safety of the boot chain (firmware/boot over the NOR emulator). Three scenarios
 * from the same board: slot A holds v1 (a factory image, booted once: floor 1), slot B a v3 that
 * was uploaded, never confirmed and rejected; the floor log's block is full, so the first raise
 * compacts it.
 *   upgrade:  upload v2 (counter 2) into B, boot (test), confirm, boot
 *   unconfirmed: upload v2 (counter 2), boot 5 times without a confirmation (3 tests, then v1)
 *   revert:   upload v2 (counter 1), boot, confirm, boot, revert, boot
 * Power is cut at every flash operation of every step, with every tear shape; then the board
 * reboots (wdr_boot_decide) and whoever ran the step retries it (the upload resent, confirm or
 * revert repeated), with a second cut, of every shape, at every operation of that recovery;
 * then it must boot what follows the step, and boots three more times with nobody confirming.
 * The same with an I/O error (flash untouched, power on) at every operation of every step. After every cut: no slot
 * whose log says bootable fails its verification (a downgrade excepted). At every boot: an
 * image runs, it is byte for byte v1 in A or v2 in B (never the rejected v3, never a mix), it
 * verifies, the floor never decreases, an unconfirmed v2 runs at most 3 times per upload, a v2
 * whose upload was cut never runs (until it is resent), and the recovery boot is what the board
 * would boot before or after the interrupted step. Prints the fault points and the violations. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "boot_test_util.h"
#include "wdr_err.h"
#include <stdio.h>
#include <string.h>

#define BLOCK 1024u
#define BLOCKS 16u
#define CHUNK 1000u   /* not a multiple of the program unit: tails in every chunk */
#define AFTER_BOOTS 4 /* boots after the recovery, nobody confirming */
#define SIGNATURE_EVERY 64 /* runs with the ECDSA step on (2 ms a verification here); the
                              others check hash and key hash, and the bytes against v1/v2 */

typedef struct outcome {
    int major;    /* version that runs: 1, 2; 0 nothing */
    bool testing;
} outcome;

enum step_kind { UPLOAD, BOOT, CONFIRM, REVERT };

typedef struct step {
    int kind;
    outcome after; /* what the next boot runs once this step is done */
} step;

typedef struct scenario {
    const char *name;
    const uint8_t *v2;
    size_t v2_len;
    int n_steps;
    step steps[8];
} scenario;

/* What the checker carries along one history of boots. */
typedef struct history {
    int running;          /* slot of the last boot */
    int test_runs;        /* boots of an unconfirmed v2 */
    uint32_t floor_max;
    bool upload_cut;      /* the v2 upload was interrupted: v2 never runs */
} history;

/* The state at the start of each step of the uncut run, to cut any step from there. */
typedef struct checkpoint {
    uint8_t bytes[BLOCK * BLOCKS], programmed[BLOCK * BLOCKS / 16];
    uint64_t ops;
    history h;
    outcome before;
} checkpoint;

static bt_flash fl;
static bt_key dev;
static uint8_t v1[8192], v2_up[8192], v2_same[8192], v3[8192];
static size_t v1_len, v2_up_len, v2_same_len, v3_len;
static uint8_t base_bytes[BLOCK * BLOCKS], base_programmed[BLOCK * BLOCKS / 16];
static checkpoint cps[8];
static const scenario *sc;
static long fault_points, violations, runs;
static bool with_signature, io_pass; /* io_pass: the faults are I/O errors, not cuts */

static void violation(const char *what, int a, int b)
{
    violations++;
    if (violations <= 20)
        printf("VIOLATION (%s, run %ld): %s (%d, %d)\n", sc->name, runs, what, a, b);
}

static wdr_boot_policy policy(void)
{
    wdr_boot_policy p = bt_policy(&dev);
    p.check_signature = with_signature;
    return p;
}

/* Which signed image the slot holds, byte for byte: 1, 2, 3, or 0 (none of them). */
static int image_in(int slot)
{
    const uint8_t *at = fl.bytes + fl.l.slot_addr[slot];
    if (slot == 0 && !memcmp(at, v1, v1_len))
        return 1;
    if (slot == 1 && !memcmp(at, sc->v2, sc->v2_len))
        return 2;
    if (slot == 1 && !memcmp(at, v3, v3_len))
        return 3;
    return 0;
}

static uint32_t raw_floor(void)
{
    wdr_boot_flash raw = bt_flash_raw(&fl);
    uint32_t v = 0;
    wdr_boot_floor_read(&raw, &fl.l, &v);
    return v;
}

/* After a cut, before the reboot: what a log calls bootable verifies. */
static void check_after_cut(void)
{
    wdr_boot_flash raw = bt_flash_raw(&fl);
    wdr_boot_policy pol = policy();
    uint32_t floor = raw_floor();
    for (int s = 0; s < 2; s++) {
        wdr_boot_slot st;
        if (wdr_boot_slot_read(&raw, &fl.l, s, &pol, floor, &st) != WDR_OK)
            violation("slot unreadable after a cut", s, 0);
        else if (st.state == WDR_SLOT_INVALID && st.verify_err != WDR_E_DOWNGRADE)
            violation("a slot the log calls bootable fails verification after a cut", s, st.verify_err);
    }
}

/* One reset: the decision, checked. Returns false when power was cut before it decided. */
static bool boot(history *h, outcome *out)
{
    wdr_boot_policy pol = policy();
    wdr_boot_decision d;
    int rc = wdr_boot_decide(&fl.f, &fl.l, &pol, &d);
    if (rc != WDR_OK) {
        if (!fl.nor.power_lost)
            violation("decide failed without a power cut", rc, 0); /* I/O errors included */
        return false;
    }
    *out = (outcome){0, d.testing};
    if (d.slot < 0) {
        violation("nothing bootable", d.slot, 0);
        return true;
    }
    int which = image_in(d.slot);
    out->major = which;
    if (which != 1 && which != 2)
        violation("the image chosen is neither v1 in A nor v2 in B", d.slot, which);
    wdr_boot_flash raw = bt_flash_raw(&fl);
    wdr_boot_policy full = bt_policy(&dev);
    wdr_image_header hdr;
    wdr_image_trailer trl;
    if (with_signature && wdr_image_verify(&raw, fl.l.slot_addr[d.slot], fl.l.image_capacity, &full, d.floor, &hdr,
                                           &trl) != WDR_OK)
        violation("the image chosen does not verify", d.slot, 0);
    uint32_t floor = raw_floor();
    if (floor < h->floor_max)
        violation("the floor decreased", (int)h->floor_max, (int)floor);
    h->floor_max = floor > h->floor_max ? floor : h->floor_max;
    if (which == 2 && h->upload_cut)
        violation("a v2 whose upload was cut runs", d.slot, 0);
    if (which == 2 && d.testing && ++h->test_runs > (int)WDR_BOOT_MAX_ATTEMPTS)
        violation("an unconfirmed v2 ran more than 3 times", h->test_runs, 0);
    h->running = d.slot;
    return true;
}

static bool same(outcome a, outcome b) { return a.major == b.major && a.testing == b.testing; }

/* Run step i; false when power was cut during it. */
static bool run_step(int i, history *h)
{
    wdr_boot_policy pol = policy();
    outcome o;
    switch (sc->steps[i].kind) {
    case UPLOAD:
        if (bt_upload(&fl, 1, sc->v2, sc->v2_len, CHUNK, &pol) != WDR_OK) {
            if (!fl.nor.power_lost && !io_pass)
                violation("upload refused without a power cut", i, 0);
            h->upload_cut = true;
        } else
            *h = (history){.running = h->running, .floor_max = h->floor_max}; /* a new v2: its own 3 tests */
        break;
    case BOOT: boot(h, &o); break;
    case CONFIRM:
        if (wdr_boot_confirm(&fl.f, &fl.l, &pol, h->running) != WDR_OK && !fl.nor.power_lost && !io_pass)
            violation("confirm refused", h->running, 0);
        break;
    case REVERT:
        if (wdr_boot_revert(&fl.f, &fl.l, &pol, h->running) != WDR_OK && !fl.nor.power_lost && !io_pass)
            violation("revert refused", h->running, 0);
        break;
    }
    return !fl.nor.power_lost;
}

static void restore(const uint8_t *bytes, const uint8_t *programmed)
{
    memcpy(fl.bytes, bytes, sizeof base_bytes);
    memcpy(fl.programmed, programmed, sizeof base_programmed);
    nor_emul_cut_power_at(&fl.nor, 0, 0);
    nor_emul_reboot(&fl.nor);
}

/* The uncut run: checkpoints before each step, and each boot as the table says. */
static void reference_run(void)
{
    with_signature = true;
    restore(base_bytes, base_programmed);
    history h = {.running = 0, .floor_max = raw_floor()};
    outcome before = {1, false};
    for (int i = 0; i < sc->n_steps; i++) {
        checkpoint *c = &cps[i];
        memcpy(c->bytes, fl.bytes, sizeof c->bytes);
        memcpy(c->programmed, fl.programmed, sizeof c->programmed);
        c->ops = fl.nor.ops;
        c->h = h;
        c->before = before;
        outcome o = {0, false};
        if (sc->steps[i].kind == BOOT) {
            assert_true(boot(&h, &o));
            assert_int_equal(o.major, before.major);
            assert_int_equal(o.testing, before.testing);
        } else
            assert_true(run_step(i, &h));
        before = sc->steps[i].after;
    }
    assert_int_equal(violations, 0);
}

/* The board's rest after a fault in step i: it must then boot what follows the step, and boot
 * AFTER_BOOTS times with nobody confirming. */
static void after_recovery(int i, history *h)
{
    outcome o = {0, false};
    if (!boot(h, &o))
        violation("a boot without a cut failed", i, 0);
    else if (!same(o, sc->steps[i].after))
        violation("after the recovery the board does not boot what follows the step", o.major, o.testing);
    for (int b = 1; b < AFTER_BOOTS; b++)
        if (!boot(h, &o))
            violation("a boot without a cut failed", i, b);
}

/* The board after a cut in step i comes back: it boots (its outcome is what it ran before or
 * after the step), and whoever ran the step runs it again unless it took effect (an upload
 * resent, confirm or revert repeated; a boot step is its own retry). False when power was cut
 * again. */
static bool recover(int i, history *h)
{
    outcome o;
    if (!boot(h, &o))
        return false;
    const checkpoint *c = &cps[i];
    if (!same(o, c->before) && !same(o, sc->steps[i].after))
        violation("the recovery boot is neither the state before nor after the step", o.major, o.testing);
    if (sc->steps[i].kind == BOOT || same(o, sc->steps[i].after))
        return true;
    return run_step(i, h);
}

/* One fault point: step i cut at its operation op with tear; the recovery (boot and retry) cut
 * at its operation op2 (0: not cut) with tear2, then recovered without a cut; then the board
 * must boot what follows the step, and boots AFTER_BOOTS times with nobody confirming.
 * Returns false when op2 was past the recovery's last operation (the cut never fired). */
static bool fault_point(int i, uint64_t op, int tear, uint64_t op2, int tear2)
{
    runs++;
    with_signature = runs % SIGNATURE_EVERY == 0;
    const checkpoint *c = &cps[i];
    restore(c->bytes, c->programmed);
    fl.nor.ops = c->ops;
    history h = c->h;
    nor_emul_cut_power_at(&fl.nor, c->ops + op, tear);
    if (run_step(i, &h)) {
        violation("the cut did not fire", i, (int)op);
        return false;
    }
    check_after_cut();
    nor_emul_reboot(&fl.nor);
    if (op2)
        nor_emul_cut_power_at(&fl.nor, fl.nor.ops + op2, tear2);
    bool recovered = recover(i, &h);
    if (op2 && !fl.nor.power_lost) {
        nor_emul_cut_power_at(&fl.nor, 0, 0);
        return false; /* the second cut never fired: that point is the single cut's */
    }
    if (!recovered) {
        check_after_cut();
        nor_emul_reboot(&fl.nor);
        if (!recover(i, &h))
            violation("a recovery without a cut failed", i, (int)op);
    }
    after_recovery(i, &h);
    fault_points++;
    return true;
}

/* An I/O error (flash untouched, power on) at operation op of step i; the step's caller sees
 * it fail (a boot decides without that record), the board resets and the step is retried. */
static void io_fault_point(int i, uint64_t op)
{
    runs++;
    with_signature = runs % SIGNATURE_EVERY == 0;
    io_pass = true;
    const checkpoint *c = &cps[i];
    restore(c->bytes, c->programmed);
    fl.nor.ops = c->ops;
    history h = c->h;
    nor_emul_fail_at(&fl.nor, c->ops + op);
    run_step(i, &h);
    if (fl.nor.fail_at)
        violation("the I/O error did not fire", i, (int)op);
    nor_emul_fail_at(&fl.nor, 0);
    check_after_cut();
    io_pass = false;
    if (!recover(i, &h))
        violation("a recovery without a fault failed", i, (int)op);
    after_recovery(i, &h);
    fault_points++;
}

/* Operations of step i in the uncut run. */
static uint64_t step_ops(int i)
{
    return (i + 1 < sc->n_steps ? cps[i + 1].ops : cps[i].ops + 64) - cps[i].ops;
}

static void run_scenario(const scenario *s)
{
    sc = s;
    reference_run();
    long before = fault_points, v_before = violations;
    uint64_t total_ops = 0;
    for (int i = 0; i < sc->n_steps; i++) {
        uint64_t n = step_ops(i);
        if (i + 1 == sc->n_steps) { /* the last step: count it by running it */
            restore(cps[i].bytes, cps[i].programmed);
            uint64_t at = fl.nor.ops;
            history h = cps[i].h;
            run_step(i, &h);
            n = fl.nor.ops - at;
        }
        total_ops += n;
        for (uint64_t op = 1; op <= n; op++)
            io_fault_point(i, op);
        for (uint64_t op = 1; op <= n; op++)
            for (int tear = NOR_TEAR_NONE; tear <= NOR_TEAR_BITS; tear++) {
                fault_point(i, op, tear, 0, 0);
                for (int tear2 = NOR_TEAR_NONE; tear2 <= NOR_TEAR_BITS; tear2++)
                    for (uint64_t op2 = 1; fault_point(i, op, tear, op2, tear2); op2++)
                        ;
            }
    }
    printf("powerloss boot %s: %llu flash operations, %ld fault points (an I/O error at each; single and "
           "double cuts, 4 tear shapes), %ld violations\n",
           sc->name, (unsigned long long)total_ops, fault_points - before, violations - v_before);
}

static void upgrade_and_confirm(void **state)
{
    (void)state;
    scenario s = {"upgrade", v2_up, v2_up_len, 4,
                  {{UPLOAD, {2, true}}, {BOOT, {2, true}}, {CONFIRM, {2, false}}, {BOOT, {2, false}}}};
    run_scenario(&s);
    assert_int_equal(violations, 0);
}

static void unconfirmed_reverts_after_three_boots(void **state)
{
    (void)state;
    scenario s = {"unconfirmed", v2_up, v2_up_len, 6,
                  {{UPLOAD, {2, true}}, {BOOT, {2, true}}, {BOOT, {2, true}}, {BOOT, {1, false}},
                   {BOOT, {1, false}}, {BOOT, {1, false}}}};
    run_scenario(&s);
    assert_int_equal(violations, 0);
}

static void confirm_then_revert(void **state)
{
    (void)state;
    scenario s = {"revert", v2_same, v2_same_len, 6,
                  {{UPLOAD, {2, true}}, {BOOT, {2, true}}, {CONFIRM, {2, false}}, {BOOT, {2, false}},
                   {REVERT, {1, false}}, {BOOT, {1, false}}}};
    run_scenario(&s);
    assert_int_equal(violations, 0);
}

/* The board every scenario starts from (see the top of the file). */
static void build_base(void)
{
    wdr_boot_policy pol = bt_policy(&dev);
    wdr_boot_decision d;
    bt_flash_init(&fl, BLOCK, BLOCKS);
    uint8_t junk[16];
    memset(junk, 0x5A, sizeof junk);
    for (uint32_t u = 0; u + 1 < BLOCK / 16; u++) /* torn units: the floor block is one record from full */
        assert_int_equal(nor_emul_prog(&fl.nor, fl.l.floor_addr[0] + u * 16, junk, 16), WDR_OK);
    bt_flash_image(&fl, 0, v1, v1_len);
    assert_int_equal(wdr_boot_decide(&fl.f, &fl.l, &pol, &d), WDR_OK);
    assert_int_equal(d.slot, 0);
    assert_int_equal(bt_upload(&fl, 1, v3, v3_len, CHUNK, &pol), WDR_OK);
    for (int b = 0; b < 4; b++)
        assert_int_equal(wdr_boot_decide(&fl.f, &fl.l, &pol, &d), WDR_OK);
    assert_int_equal(d.slot, 0);
    assert_int_equal(d.slots[1].state, WDR_SLOT_REJECTED);
    assert_int_equal(d.floor, 1);
    memcpy(base_bytes, fl.bytes, sizeof base_bytes);
    memcpy(base_programmed, fl.programmed, sizeof base_programmed);
}

static int setup(void **state)
{
    (void)state;
    bt_key_dev(&dev);
    bt_image_spec s = bt_spec(1, 1, 2048);
    v1_len = bt_image_build(v1, sizeof v1, &s, &dev, NULL);
    s = bt_spec(2, 2, 4000);
    v2_up_len = bt_image_build(v2_up, sizeof v2_up, &s, &dev, NULL);
    s = bt_spec(2, 1, 4000);
    s.seed = 9;
    v2_same_len = bt_image_build(v2_same, sizeof v2_same, &s, &dev, NULL);
    s = bt_spec(3, 1, 3008);
    v3_len = bt_image_build(v3, sizeof v3, &s, &dev, NULL);
    build_base();
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    printf("powerloss boot: %ld fault points in all, %ld violations\n", fault_points, violations);
    return 0;
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(upgrade_and_confirm),
        cmocka_unit_test(unconfirmed_reverts_after_three_boots),
        cmocka_unit_test(confirm_then_revert),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
