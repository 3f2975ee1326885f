/* Tables for tests, built with the formats' own encoders (wdr_lut_encode, wdr_cal_encode). */
#ifndef TABLE_BUILDERS_H
#define TABLE_BUILDERS_H
#include <stddef.h>
#include <stdint.h>

/* A LUT of n entries (rising codes from code0, 100 ticks apart, 1 ns ticks). Returns its size. */
size_t th_make_lut(uint8_t *out, uint32_t n, uint16_t code0, uint8_t dac_bits);

/* A Moebius calibration table (12-bit codes) whose every pixel maps y to gain*y + offset.
 * w*h at most 4096*64. Returns its size. */
size_t th_make_cal(uint8_t *out, float gain, float offset, uint32_t sensor_id, uint16_t w, uint16_t h);

/* A BASIS calibration table (12-bit codes, minor version 1): shared functions B0 = 1 and
 * B1 = th_basis_curve(y) at points every 4 codes (0..4096), pixel (r, c) with coefficients
 * 10 + r / 2 and 0.5 + c / 1000, so it maps y to th_basis_expect(r, c, y). With poison set, one
 * shared value is NaN (the CRCs still match). w*h at most 4096*64. Returns its size. */
size_t th_make_cal_basis(uint8_t *out, uint32_t sensor_id, uint16_t w, uint16_t h, int poison);
float th_basis_curve(float y);
float th_basis_expect(int row, int col, float y);

/* The table of issue 14: BASIS, 4 coefficients, shared_points 0x40000001, so that
 * shared_points * n_coeffs wraps to 4 in u32 (16 bytes of shared block, header and payload CRCs
 * right). A parser that multiplies in u32 takes it and reads 16 GiB past its buffer. */
#define TH_WRAPPED_POINTS 0x40000001u
size_t th_make_cal_wrapped(uint8_t *out, uint32_t sensor_id, uint16_t w, uint16_t h);

#endif
