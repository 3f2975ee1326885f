/* Planted fault for the layer check: a program's main left in a backend's folder (where
 * wdr-simboard's was before issue 22) includes the host's command-line tables. */
#include "cli_options.h"
