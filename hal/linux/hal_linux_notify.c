/* systemd's service notification (sd_notify(3)) without libsystemd: one datagram with the
 * state ("READY=1", "STOPPING=1") to the AF_UNIX socket named by $NOTIFY_SOCKET, which is a
 * path or, with a leading '@', an abstract name. Without the variable (not under systemd,
 * Type=simple) it does nothing. */
#include "hal_linux_internal.h"
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

void lx_notify(const char *state)
{
    const char *path = getenv("NOTIFY_SOCKET");
    struct sockaddr_un addr = {.sun_family = AF_UNIX};
    size_t n = path ? strlen(path) : 0;
    if (n == 0 || n >= sizeof addr.sun_path || (path[0] != '/' && path[0] != '@'))
        return;
    memcpy(addr.sun_path, path, n);
    if (path[0] == '@')
        addr.sun_path[0] = 0; /* abstract namespace: the length below says where it ends */
    int fd = socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    if (fd < 0)
        return;
    socklen_t len = (socklen_t)(offsetof(struct sockaddr_un, sun_path) + n);
    if (sendto(fd, state, strlen(state), MSG_NOSIGNAL, (struct sockaddr *)&addr, len) < 0) {
        /* systemd went away: nothing to tell */
    }
    close(fd);
}
