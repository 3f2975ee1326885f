/* The image target's seed writer (make_seeds_image.c), called by make_seeds.c's main. */
#ifndef MAKE_SEEDS_IMAGE_H
#define MAKE_SEEDS_IMAGE_H
#include <stddef.h>

typedef void (*image_seed_put)(const char *target, const char *name, const void *data, size_t n);
void make_image_seeds(image_seed_put put);

#endif
