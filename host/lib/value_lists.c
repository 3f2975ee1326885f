/* Completion values (see value_lists.h). */
#include "value_lists.h"
#include "data_path.h"
#include "operators.h"
#include <glob.h>
#include <string.h>

/* Every transport's prefix, and the serial ports present now. */
static void print_devices(FILE *f)
{
    static const char *const ports[] = {"/dev/ttyACM*", "/dev/ttyUSB*"};
    fputs("usb\nusb:\nsim:\nunix:\ntcp:\nserial:\n", f);
    for (size_t k = 0; k < sizeof ports / sizeof *ports; k++) {
        glob_t g;
        if (glob(ports[k], 0, NULL, &g) == 0)
            for (size_t i = 0; i < g.gl_pathc; i++)
                fprintf(f, "serial:%s\n", g.gl_pathv[i]);
        globfree(&g);
    }
}

void wdr_print_values(FILE *f, const char *kind)
{
    if (wdr_data_print_names(f, kind))
        return;
    if (!strcmp(kind, "devices"))
        print_devices(f);
    else if (!strcmp(kind, "operators"))
        for (int id = 0; wdr_operator_info_by_id(id); id++)
            fprintf(f, "%s\n", wdr_operator_info_by_id(id)->name);
}
