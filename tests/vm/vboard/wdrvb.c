// SPDX-License-Identifier: GPL-2.0
/* wdrvb: the wdrcam virtual board for the VM test. It stands in for the sensor's control lines
 * and converters on a real kernel, so that hal/linux runs unmodified:
 *   - a gpiochip "wdrvb" on gpiolib (reset, row select, ADC convert, row address bits: the
 *     offsets and names of vboard_pins.h, which boards/vm-wdrvb/wdr-board.json describes);
 *   - an SPI controller, bus 0, with spidev bound to chip select 0 (ramp DAC) and 1 (column ADC);
 *   - a sensor model (vboard_model.h): the DAC words played since the release of reset are the
 *     ramp, a convert latches the selected row, an ADC read shifts out that row's codes.
 * It counts every protocol error it sees; /sys/devices/platform/wdrvb/counters lists them.
 * Module parameter unbound_line=N leaves line N unconnected: driving it changes nothing and it
 * reads 0, as a pin with no wire would (for wdr-board --self-test). */
#include <linux/gpio/driver.h>
#include <linux/module.h>
#include <linux/mutex.h>
#include <linux/platform_device.h>
#include <linux/slab.h>
#include <linux/spi/spi.h>
#include <linux/vmalloc.h>
#include <linux/version.h>

#include "vboard_pins.h"
#include "vboard_model.h"

#define VB_LINES 32u
#define VB_CS_DAC 0u
#define VB_CS_ADC 1u
#define VB_CODE_MAX ((1u << VB_DAC_BITS) - 1u)

static struct platform_device *vb_pdev;
static struct gpio_chip vb_chip;
static struct spi_controller *vb_ctlr;
static DEFINE_MUTEX(vb_lock);

static int unbound_line = -1;
module_param(unbound_line, int, 0444);
MODULE_PARM_DESC(unbound_line, "a line offset left unconnected (-1: none)");

static const char *vb_line_names[VB_LINES];

static struct {
	unsigned long lines;      /* line values */
	u16 *steps;               /* DAC words since the release of reset */
	unsigned int n_steps;
	int latched_row;          /* row latched by the last convert, -1: none */
	/* activity */
	u64 resets, dac_words, conversions, adc_reads;
	/* protocol errors: all must stay zero */
	u64 reads_without_convert, converts_without_select, dac_out_of_range, bad_lengths,
	    steps_overflow, reads_without_ramp, bad_row;
} vb;

/* ---- Control lines and the model's reaction to their edges ---------------------------------- */

static unsigned int row_address(unsigned long lines)
{
	return (lines >> VB_LINE_ROW_ADDR0) & ((1u << VB_ROW_ADDR_BITS) - 1u);
}

/* Called with vb_lock held after the lines changed from old to vb.lines. */
static void on_edges(unsigned long old)
{
	unsigned long rose = vb.lines & ~old, fell = old & ~vb.lines;

	if (fell & BIT(VB_LINE_RESET)) { /* release of reset: t = 0 of a new ramp */
		vb.n_steps = 0;
		vb.latched_row = -1;
		vb.resets++;
	}
	if (rose & BIT(VB_LINE_ADC_CONVERT)) {
		if (!(vb.lines & BIT(VB_LINE_ROW_SELECT))) {
			vb.converts_without_select++;
			return;
		}
		if (row_address(vb.lines) >= VB_HEIGHT) {
			vb.bad_row++;
			return;
		}
		vb.latched_row = (int)row_address(vb.lines);
		vb.conversions++;
	}
}

static int vb_get(struct gpio_chip *gc, unsigned int offset)
{
	int v;

	mutex_lock(&vb_lock);
	v = !!(vb.lines & BIT(offset));
	mutex_unlock(&vb_lock);
	return v;
}

static void vb_set_multiple(struct gpio_chip *gc, unsigned long *mask, unsigned long *bits)
{
	unsigned long old;

	mutex_lock(&vb_lock);
	old = vb.lines;
	vb.lines = (vb.lines & ~*mask) | (*bits & *mask);
	if (unbound_line >= 0 && unbound_line < (int)VB_LINES)
		vb.lines &= ~BIT(unbound_line); /* no wire: it never follows */
	on_edges(old);
	mutex_unlock(&vb_lock);
}

static void vb_set(struct gpio_chip *gc, unsigned int offset, int value)
{
	unsigned long mask = BIT(offset), bits = value ? BIT(offset) : 0;

	vb_set_multiple(gc, &mask, &bits);
}

static int vb_direction_output(struct gpio_chip *gc, unsigned int offset, int value)
{
	vb_set(gc, offset, value);
	return 0;
}

static int vb_direction_input(struct gpio_chip *gc, unsigned int offset)
{
	return 0;
}

static int vb_get_direction(struct gpio_chip *gc, unsigned int offset)
{
	return GPIO_LINE_DIRECTION_OUT;
}

/* ---- Kernel API differences (6.1 and 6.12 both run this module) ---------------------------- */

/* Chip select accessors arrived in 6.3 (multiple chip selects per device). */
static u8 vb_cs(const struct spi_device *spi)
{
#if LINUX_VERSION_CODE >= KERNEL_VERSION(6, 3, 0)
	return spi_get_chipselect(spi, 0);
#else
	return spi->chip_select;
#endif
}

/* From 6.9 a device has SPI_CS_CNT_MAX chip select slots and the core compares every slot of
 * every device on the bus: the unused ones must say "none" (0xff, the core's SPI_INVALID_CS),
 * or the second device collides with the first one's slot 0. */
static void vb_set_cs(struct spi_device *spi, u8 cs)
{
#if LINUX_VERSION_CODE >= KERNEL_VERSION(6, 3, 0)
	spi_set_chipselect(spi, 0, cs);
#ifdef SPI_CS_CNT_MAX
	{
		unsigned int i;

		for (i = 1; i < SPI_CS_CNT_MAX; i++)
			spi_set_chipselect(spi, i, 0xff);
	}
#endif
#else
	spi->chip_select = cs;
#endif
}

/* driver_override moved from spi_device into struct device in the 6.12 stable series; kbuild
 * finds which (VB_DEVICE_DRIVER_OVERRIDE, see tests/vm/vm_prepare.sh). */
static int vb_bind_spidev(struct spi_device *spi)
{
#ifdef VB_DEVICE_DRIVER_OVERRIDE
	return device_set_driver_override(&spi->dev, "spidev");
#else
	spi->driver_override = kstrdup("spidev", GFP_KERNEL);
	return spi->driver_override ? 0 : -ENOMEM;
#endif
}

/* ---- Converters on SPI ----------------------------------------------------------------------- */

static void dac_words(const u8 *tx, unsigned int len)
{
	unsigned int i;

	if (!tx || len % 2) {
		vb.bad_lengths++;
		return;
	}
	for (i = 0; i < len; i += 2) {
		u16 code = (u16)(tx[i] << 8 | tx[i + 1]);

		vb.dac_words++;
		if (code > VB_CODE_MAX)
			vb.dac_out_of_range++;
		if (vb.n_steps == VB_MAX_STEPS)
			vb.steps_overflow++;
		else
			vb.steps[vb.n_steps++] = code;
	}
}

/* One row of 16-bit big-endian codes, from the row latched by the last convert. */
static void adc_row(u8 *rx, unsigned int len)
{
	unsigned int col;
	int row = vb.latched_row;

	vb.adc_reads++;
	vb.latched_row = -1; /* one convert, one read */
	if (!rx || len != VB_WIDTH * 2u) {
		vb.bad_lengths++;
		return;
	}
	if (row < 0)
		vb.reads_without_convert++;
	else if (vb.n_steps == 0)
		vb.reads_without_ramp++;
	for (col = 0; col < VB_WIDTH; col++) {
		u16 code = 0;

		if (row >= 0 && vb.n_steps)
			code = vb.steps[vb_pixel_step((unsigned int)row, col, vb.n_steps)];
		rx[2 * col] = (u8)(code >> 8);
		rx[2 * col + 1] = (u8)code;
	}
}

static int vb_transfer_one(struct spi_controller *ctlr, struct spi_device *spi, struct spi_transfer *t)
{
	mutex_lock(&vb_lock);
	if (vb_cs(spi) == VB_CS_DAC)
		dac_words(t->tx_buf, t->len);
	else
		adc_row(t->rx_buf, t->len);
	mutex_unlock(&vb_lock);
	return 0; /* done: no transfer in flight */
}

/* spidev on a chip select, bound by driver_override (no device tree here). */
static int add_spidev(unsigned int cs, const char *name)
{
	struct spi_device *spi = spi_alloc_device(vb_ctlr);
	int rc;

	if (!spi)
		return -ENOMEM;
	vb_set_cs(spi, cs);
	spi->max_speed_hz = VB_SPI_HZ;
	spi->mode = SPI_MODE_0;
	strscpy(spi->modalias, name, sizeof spi->modalias);
	rc = vb_bind_spidev(spi);
	if (!rc)
		rc = spi_add_device(spi);
	if (rc)
		spi_dev_put(spi);
	return rc;
}

/* ---- Counters in sysfs ------------------------------------------------------------------------- */

static ssize_t counters_show(struct device *dev, struct device_attribute *attr, char *buf)
{
	ssize_t n;

	mutex_lock(&vb_lock);
	n = sysfs_emit(buf,
		       "resets %llu\ndac_words %llu\nconversions %llu\nadc_reads %llu\n"
		       "reads_without_convert %llu\nconverts_without_select %llu\ndac_out_of_range %llu\n"
		       "bad_lengths %llu\nsteps_overflow %llu\nreads_without_ramp %llu\nbad_row %llu\n",
		       vb.resets, vb.dac_words, vb.conversions, vb.adc_reads, vb.reads_without_convert,
		       vb.converts_without_select, vb.dac_out_of_range, vb.bad_lengths, vb.steps_overflow,
		       vb.reads_without_ramp, vb.bad_row);
	mutex_unlock(&vb_lock);
	return n;
}
static DEVICE_ATTR_RO(counters);

/* ---- Module ------------------------------------------------------------------------------------ */

static void vb_teardown(void)
{
	if (vb_ctlr)
		spi_unregister_controller(vb_ctlr);
	vb_ctlr = NULL;
	if (vb_chip.parent)
		gpiochip_remove(&vb_chip);
	vb_chip.parent = NULL;
	if (vb_pdev) {
		device_remove_file(&vb_pdev->dev, &dev_attr_counters);
		platform_device_unregister(vb_pdev);
	}
	vb_pdev = NULL;
	vfree(vb.steps);
	vb.steps = NULL;
}

static int __init vb_init(void)
{
	int rc;

	vb.latched_row = -1;
	vb.steps = vzalloc(VB_MAX_STEPS * sizeof *vb.steps);
	if (!vb.steps)
		return -ENOMEM;
	vb_pdev = platform_device_register_simple("wdrvb", -1, NULL, 0);
	if (IS_ERR(vb_pdev)) {
		rc = PTR_ERR(vb_pdev);
		vb_pdev = NULL;
		goto fail;
	}
	rc = device_create_file(&vb_pdev->dev, &dev_attr_counters);
	if (rc)
		goto fail;

	vb_line_names[VB_LINE_RESET] = VB_NAME_RESET;
	vb_line_names[VB_LINE_ROW_SELECT] = VB_NAME_ROW_SELECT;
	vb_line_names[VB_LINE_ADC_CONVERT] = VB_NAME_ADC_CONVERT;
	vb_chip = (struct gpio_chip){
		.label = "wdrvb", .parent = &vb_pdev->dev, .owner = THIS_MODULE, .base = -1,
		.ngpio = VB_LINES, .names = vb_line_names, .can_sleep = true, .get = vb_get, .set = vb_set,
		.set_multiple = vb_set_multiple, .direction_output = vb_direction_output,
		.direction_input = vb_direction_input, .get_direction = vb_get_direction,
	};
	rc = gpiochip_add_data(&vb_chip, NULL);
	if (rc) {
		vb_chip.parent = NULL;
		goto fail;
	}

	vb_ctlr = spi_alloc_master(&vb_pdev->dev, 0);
	if (!vb_ctlr) {
		rc = -ENOMEM;
		goto fail;
	}
	vb_ctlr->bus_num = 0;
	vb_ctlr->num_chipselect = 2;
	vb_ctlr->mode_bits = SPI_CPOL | SPI_CPHA;
	vb_ctlr->bits_per_word_mask = SPI_BPW_MASK(8);
	vb_ctlr->max_speed_hz = VB_SPI_HZ;
	vb_ctlr->transfer_one = vb_transfer_one;
	rc = spi_register_controller(vb_ctlr);
	if (rc) {
		spi_controller_put(vb_ctlr);
		vb_ctlr = NULL;
		goto fail;
	}
	rc = add_spidev(VB_CS_DAC, "wdrvb-dac");
	if (!rc)
		rc = add_spidev(VB_CS_ADC, "wdrvb-adc");
	if (rc)
		goto fail;
	pr_info("wdrvb: gpiochip base %d, spi bus 0 (DAC cs0, ADC cs1), %ux%u sensor model\n",
		vb_chip.base, VB_WIDTH, VB_HEIGHT);
	return 0;
fail:
	pr_err("wdrvb: init failed: %d\n", rc);
	vb_teardown();
	return rc;
}

static void __exit vb_exit(void)
{
	vb_teardown();
}

module_init(vb_init);
module_exit(vb_exit);
MODULE_DESCRIPTION("wdrcam virtual board: gpiochip, SPI converters and sensor model for the VM test");
MODULE_LICENSE("GPL");
