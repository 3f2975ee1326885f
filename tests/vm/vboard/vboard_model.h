/* The sensor model of the virtual board (wdrvb.ko), shared by the kernel module that plays it
 * and by the VM test's frame checker, so that both sides agree on what a pixel must read.
 *
 * Every pixel holds the DAC code of one ramp step: the step at which its photodiode node
 * crossed V_ref. Which step is a fixed scramble of (row, column) over the steps played since
 * the last release of reset, so a capture exercises row addressing, column order, byte order
 * and the ramp playback order at once. Plain C, no headers: the kernel and user space both
 * include it. */
#ifndef VBOARD_MODEL_H
#define VBOARD_MODEL_H

#define VB_MAX_STEPS 65536u /* DAC words remembered per frame */

/* The ramp step (0..n_steps-1) whose code pixel (row, col) holds. */
static inline unsigned int vb_pixel_step(unsigned int row, unsigned int col, unsigned int n_steps)
{
    unsigned int h = row * 2654435761u ^ (col + 0x9e37u) * 40503u;
    h ^= h >> 13;
    h *= 0x5bd1e995u;
    h ^= h >> 15;
    return n_steps ? h % n_steps : 0u;
}

#endif
