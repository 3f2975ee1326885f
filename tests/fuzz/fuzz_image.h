/* Target image's input layout, shared by the harness (fuzz_image.c) and its seed writer
 * (make_seeds_image.c): [flags u8][cut u8][the image flash's bytes, erased past the input]. */
#ifndef FUZZ_IMAGE_H
#define FUZZ_IMAGE_H

#define FZI_BLOCK 1024u
#define FZI_BLOCKS 8u            /* floor log 2 blocks, slots of 3 (image capacity 2 KiB) */
#define FZI_FLASH (FZI_BLOCK * FZI_BLOCKS)

#define FZI_SIGNATURE 0x01u      /* check signatures (2 ms each: off, the hash and key hash still hold) */
#define FZI_FIX_HASHES 0x02u     /* recompute each slot's trailer SHA-256 and key hash, so mutated
                                    headers reach the checks after the hash */
#define FZI_CONFIRM 0x04u        /* confirm the slot that boots, then boot again */
#define FZI_REVERT 0x08u         /* revert the slot that boots, then boot again */
#define FZI_TEAR_SHIFT 4         /* bits 4-5: tear shape of the cut (enum nor_tear) */
/* cut: cut power at that operation of the first boot (0: none), reboot and boot again */

#endif
