/* --version of every program: the project's version and the versions of the wire protocol and
 * table formats it speaks, straight from the firmware's format headers. */
#include "cli_options.h"
#include "wdr_cal.h"
#include "wdr_fw_config.h"
#include "wdr_lut.h"
#include "wdr_proto.h"
#include "wdr_store.h"

#ifndef WDR_VERSION
#error "WDR_VERSION (the project's version) comes from CMake"
#endif

void cli_print_version(FILE *f, const char *prog)
{
    fprintf(f, "%s (wdrcam) %s\n", prog, WDR_VERSION);
    fprintf(f, "wire protocol %d.%d, LUT table format %d.%d, calibration table format %d.%d, flash slot format %d.%d\n",
            WDR_PROTO_VERSION_MAJOR, WDR_PROTO_VERSION_MINOR, WDR_LUT_VERSION_MAJOR, WDR_LUT_VERSION_MINOR,
            WDR_CAL_VERSION_MAJOR, WDR_CAL_VERSION_MINOR, WDR_SLOT_VERSION_MAJOR, WDR_SLOT_VERSION_MINOR);
    fprintf(f, "firmware %d.%d (the version a board built from this tree reports)\n", WDR_FW_VERSION_MAJOR,
            WDR_FW_VERSION_MINOR);
}
