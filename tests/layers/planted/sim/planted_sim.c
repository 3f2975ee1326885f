/* Planted fault for the layer check: the physics includes a host header. */
#include "planted_host.h"
